"""Typed settings of the ROS 1 Kinect input (``[services.tracker.config.ros1]``)."""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec
from msgspec import Meta

from handover_model import scene

TopicName = Annotated[str, Meta(min_length=1, max_length=200, pattern=r"^/[A-Za-z0-9_/]+$")]
FrameId = Annotated[str, Meta(min_length=1, max_length=200, pattern=r"^/?[A-Za-z0-9_/]+$")]


class Ros1KinectTopics(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """ROS 1 topics on the camera's side (``[services.tracker.config.ros1.topics]``).

    Attributes:
        tf: ``tf2_msgs/TFMessage``: openni_tracker's joint frames (and whatever else ``/tf`` carries).
        depth_image: ``sensor_msgs/Image``, ``16UC1`` mm (openni_launch's ``image_raw``) or ``32FC1`` m.
        camera_info: ``sensor_msgs/CameraInfo`` of that image (its ``K`` gives the intrinsics).
    """

    tf: TopicName = "/tf"
    depth_image: TopicName = "/camera/depth/image_raw"
    camera_info: TopicName = "/camera/depth/camera_info"


def _transfer_centre() -> list[float]:
    return [float(v) for v in scene.TABLE_TOP_CENTRE_BASE_M]


class Ros1KinectConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The ROS 1 Kinect input (docs/kinect_ros1.md).

    Attributes:
        key_format, key_namespace: how the Zenoh ROS 1 bridge names keys (as the Baxter
            backend's ``[services.bridge.config.baxter]``: ``plugin`` or ``plain``).
        topics: the ROS topics.
        calibration_file: the camera's pose in `base` (a TOML file, relative to the profile's
            folder; `services.tracker.ros1.calibration`). Required.
        skeleton_frame_id: the frame openni_tracker publishes the joints in (its
            ``camera_frame_id``); transforms relative to another frame are ignored.
        depth_frame_id: the depth image's optical frame (same origin as the skeleton's frame,
            z forward, x right, y down); an image in another frame is dropped.
        frame_spread_s: the 15 joint transforms of one skeleton frame are stamped within this
            of each other (openni_tracker sends them one by one), s.
        transfer_centre_m: the centre of the transfer region, m, `base` (default: the middle of
            the table top, where the handover happens).
        max_receiver_distance_m: a user whose torso is farther than this (horizontally, x-y)
            from `transfer_centre_m` is never the receiver, m.
        switch_margin_m: another user becomes the receiver only when nearer the transfer
            centre than the current receiver by more than this (or when the receiver is lost), m.
        user_lost_s: a user without a complete skeleton frame for this long is forgotten, s.
        no_data_warning_s: warn (once per spell) when no skeleton or no depth arrived for this long, s.
    """

    key_format: Literal["plugin", "plain"] = "plugin"
    key_namespace: Annotated[str, Meta(max_length=100, pattern=r"^[A-Za-z0-9_/]*$")] = ""
    topics: Ros1KinectTopics = Ros1KinectTopics()
    calibration_file: Annotated[str, Meta(max_length=4096)] = ""
    skeleton_frame_id: FrameId = "openni_depth_frame"
    depth_frame_id: FrameId = "camera_depth_optical_frame"
    frame_spread_s: Annotated[float, Meta(gt=0.0, le=0.1)] = 0.015
    transfer_centre_m: Annotated[list[Annotated[float, Meta(ge=-10.0, le=10.0)]],
                                 Meta(min_length=3, max_length=3)] = msgspec.field(default_factory=_transfer_centre)
    max_receiver_distance_m: Annotated[float, Meta(gt=0.0, le=10.0)] = 1.5
    switch_margin_m: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.3
    user_lost_s: Annotated[float, Meta(gt=0.0, le=10.0)] = 0.5
    no_data_warning_s: Annotated[float, Meta(gt=0.0, le=60.0)] = 2.0
