"""The fake OpenNI camera: the simulated Kinect sent as openni_tracker and openni_launch send
a real one, ROS 1 bytes on the Zenoh ROS 1 bridge's keys (docs/kinect_ros1.md).

The fake Baxter runs it on a thread (``[services.fake_baxter.config.openni] enabled = true``,
or ``--openni``) in place of the simulated Kinect's bus output: it renders the scene's own
receiver (`robot_sim.kinect.KinectSim`, 30 Hz, through `KinectThread`) and sends, per frame,

- for each user and each of the 15 joints, one ``tf2_msgs/TFMessage`` on ``/tf`` with the
  transform ``<skeleton_frame_id> → <joint>_<user>`` (the joint in the camera frame: x forward,
  y left, z up; identity rotation), one message per joint as openni_tracker's
  ``sendTransform`` calls do; the receiver is user 1, and with ``bystander_offset_m`` a second
  person (user 2, the receiver's body shifted by that offset in `base`) stands in view;
- the depth image as ``sensor_msgs/Image`` ``16UC1`` (mm) in ``<depth_frame_id>`` (the optical
  frame) and its ``sensor_msgs/CameraInfo`` (the simulated camera's intrinsics in ``K``, ``P``).

The camera frame is where the simulated camera really is (`robot_sim.kinect.camera`: on
Baxter's head, looking down at the receiver): not the identity, so the tracker's calibration
must hold that pose for the skeleton to land on the receiver (deploy/kinect_calibration_fake.toml).
Sim truth (`sim/kinect_truth`) still goes on the bus, for tests and the recorder.
"""

from __future__ import annotations

import time
from typing import Annotated, Any

import msgspec
import numpy as np
from msgspec import Meta

from bus_schema.messages import SKELETON_JOINTS
from services.bridge.baxter.errors import BaxterConfigError
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import Header, Vector3
from services.bridge.baxter.ros1 import Time
from services.sim_kinect.config import KinectConfig
from services.sim_kinect.thread import KinectThread
from services.tracker.ros1.calibration import CameraPose
from services.tracker.ros1.config import Ros1KinectConfig
from services.tracker.ros1.messages import CameraInfo, Image, TFMessage, Transform, TransformStamped

#: openni_tracker's id of the receiver, and of the bystander.
RECEIVER_USER = 1
BYSTANDER_USER = 2


class FakeOpenNIConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """``[services.fake_baxter.config.openni]``.

    Attributes:
        enabled: send the simulated Kinect as ROS 1 OpenNI messages instead of bus messages.
        bystander_offset_m: empty, or (x, y, z) m in `base`: a second person, the receiver's
            body shifted by this, is tracked too (user 2).
    """

    enabled: bool = False
    bystander_offset_m: Annotated[list[Annotated[float, Meta(ge=-10.0, le=10.0)]], Meta(max_length=3)] = []

    def __post_init__(self) -> None:
        if len(self.bystander_offset_m) not in (0, 3):
            raise msgspec.ValidationError("bystander_offset_m needs 3 values (x, y, z) or none - at "
                                          "`$.bystander_offset_m`")


def joint_transforms(joints_base_m: np.ndarray, user: int, pose: CameraPose, frame_id: str,
                     seq: int) -> list[TFMessage]:
    """openni_tracker's messages for one user's frame: one ``TFMessage`` per joint, each
    stamped when made, joints (15, 3) m in `base` given in the camera frame of `pose`."""
    in_camera = pose.from_base(joints_base_m)
    out = []
    for name, p in zip(SKELETON_JOINTS, in_camera, strict=True):
        header = Header(seq=seq, stamp=Time.from_ns(time.time_ns()), frame_id=frame_id)
        out.append(TFMessage((TransformStamped(header, f"{name}_{user}",
                                               Transform(Vector3(float(p[0]), float(p[1]), float(p[2])))),)))
    return out


def depth_messages(depth_fields: dict[str, Any], frame_id: str, seq: int) -> tuple[Image, CameraInfo]:
    """openni_launch's depth image (``16UC1`` mm) and camera info of a simulated frame's
    `bus_schema.messages.DepthImage` fields."""
    header = Header(seq=seq, stamp=Time.from_ns(time.time_ns()), frame_id=frame_id)
    w, h = depth_fields["width"], depth_fields["height"]
    fx, fy, cx, cy = (float(depth_fields[k]) for k in ("fx", "fy", "cx", "cy"))
    image = Image(header, h, w, "16UC1", 0, 2 * w, bytes(depth_fields["depth_mm"]))
    info = CameraInfo(header, h, w, "plumb_bob", (0.0,) * 5, (fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0),
                      P=(fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0))
    return image, info


def skeleton_array(skeleton_fields: dict[str, Any]) -> np.ndarray | None:
    """(15, 3) joints, m, `base`, of a tracked frame's `Skeleton` fields; None when not tracked."""
    if not skeleton_fields["tracked"]:
        return None  # openni_tracker sends nothing for a user it does not track
    by_name = {j.name: j.position_m for j in skeleton_fields["joints"]}
    return np.array([by_name[n] for n in SKELETON_JOINTS], float)


class OpenNIThread(KinectThread):
    """The simulated Kinect sent as ROS 1 OpenNI messages (see the module docstring).

    Args:
        config: the simulated Kinect (rate, body, seed).
        node: the host's open `ServiceNode` (its session carries the ROS 1 keys).
        openni: ``[services.fake_baxter.config.openni]``.
        ros1: the tracker's ``[services.tracker.config.ros1]`` (topics, key mapping, frame ids).
    """

    def __init__(self, config: KinectConfig, node: Any, openni: FakeOpenNIConfig, ros1: Ros1KinectConfig) -> None:
        self._ros1 = ros1
        self._offset = np.array(openni.bystander_offset_m, float) if openni.bystander_offset_m else None
        self._seq = 0
        self.messages = 0
        super().__init__(config, node)
        self.pose = CameraPose.from_optical(self.sim.camera.position_m, self.sim.camera.rotation)

    def _declare_outputs(self, node: Any) -> None:
        r = self._ros1

        def key(topic: str, cls: Any) -> str:
            return topic_key(topic, cls.TYPE, r.key_format, r.key_namespace)

        session = node.session
        self._tf_pub = session.declare_publisher(key(r.topics.tf, TFMessage))
        self._image_pub = session.declare_publisher(key(r.topics.depth_image, Image))
        self._info_pub = session.declare_publisher(key(r.topics.camera_info, CameraInfo))

    def _publish(self, frame: Any) -> None:
        self._seq += 1
        joints = skeleton_array(frame.skeleton_fields)
        users = [] if joints is None else [(RECEIVER_USER, joints)]
        if joints is not None and self._offset is not None:
            users.append((BYSTANDER_USER, joints + self._offset))
        for user, body in users:
            for msg in joint_transforms(body, user, self.pose, self._ros1.skeleton_frame_id, self._seq):
                self._tf_pub.put(msg.to_bytes())
                self.messages += 1
        image, info = depth_messages(frame.depth_fields, self._ros1.depth_frame_id, self._seq)
        self._info_pub.put(info.to_bytes())
        self._image_pub.put(image.to_bytes())
        self.messages += 2


def camera_thread(kinect: KinectConfig, openni: FakeOpenNIConfig, node: Any,
                  ros1: Ros1KinectConfig | None) -> KinectThread | None:
    """The fake Baxter's camera: ROS 1 OpenNI (`openni.enabled`), the bus Kinect
    (`kinect.enabled`) or none. Not started."""
    if openni.enabled:
        return OpenNIThread(kinect, node, openni, ros1 or Ros1KinectConfig())
    return KinectThread(kinect, node) if kinect.enabled else None


def fake_ros1_config(profile: Any) -> Ros1KinectConfig:
    """The tracker's ``[services.tracker.config.ros1]`` of `profile` (topics, keys, frames), so
    the fake and the tracker agree.

    Raises:
        BaxterConfigError: the table is invalid.
    """
    table = profile.service_config("tracker").get("ros1", {})
    try:
        return msgspec.convert(table, Ros1KinectConfig)
    except msgspec.ValidationError as exc:
        raise BaxterConfigError(f"invalid [services.tracker.config.ros1]: {exc}") from None
