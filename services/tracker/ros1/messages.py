"""The ROS 1 message types of the Kinect path: ``/tf`` (``tf2_msgs/TFMessage``) and the depth
camera's ``sensor_msgs/Image`` and ``sensor_msgs/CameraInfo``.

Same machinery as the Baxter backend (`services.bridge.baxter.ros1`: rosbags' ROS 1 Noetic
type store, the wire format, the MD5 sums): the standard definitions come from the store;
``tf2_msgs/TFMessage`` is not in it and is registered here from its one-line ``.msg``. The
MD5 sums equal the published ones (tests check them). Units as ROS: metres, unit quaternions,
``time`` stamps of the sender's clock; an image's ``data`` is `bytes`.
"""

from __future__ import annotations

from dataclasses import dataclass

from services.bridge.baxter.messages import Header, Vector3
from services.bridge.baxter.ros1 import Ros1Message, message_class


@message_class("geometry_msgs/Quaternion")
@dataclass(frozen=True)
class Quaternion(Ros1Message):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


@message_class("geometry_msgs/Transform")
@dataclass(frozen=True)
class Transform(Ros1Message):
    translation: Vector3 = Vector3()
    rotation: Quaternion = Quaternion()


@message_class("geometry_msgs/TransformStamped")
@dataclass(frozen=True)
class TransformStamped(Ros1Message):
    """The pose of `child_frame_id` in ``header.frame_id`` (translation in m)."""

    header: Header = Header()
    child_frame_id: str = ""
    transform: Transform = Transform()


@message_class("tf2_msgs/TFMessage", "geometry_msgs/TransformStamped[] transforms\n")
@dataclass(frozen=True)
class TFMessage(Ros1Message):
    """What ``/tf`` carries (tf's `TransformBroadcaster` sends one per `sendTransform`)."""

    transforms: tuple[TransformStamped, ...] = ()


@message_class("sensor_msgs/Image")
@dataclass(frozen=True)
class Image(Ros1Message):
    """An image; a depth image is ``16UC1`` (mm) or ``32FC1`` (m), rows of `step` bytes."""

    header: Header = Header()
    height: int = 0
    width: int = 0
    encoding: str = ""
    is_bigendian: int = 0
    step: int = 0
    data: bytes = b""


@message_class("sensor_msgs/RegionOfInterest")
@dataclass(frozen=True)
class RegionOfInterest(Ros1Message):
    x_offset: int = 0
    y_offset: int = 0
    height: int = 0
    width: int = 0
    do_rectify: bool = False


@message_class("sensor_msgs/CameraInfo")
@dataclass(frozen=True)
class CameraInfo(Ros1Message):
    """A camera's calibration; `K` is the 3x3 intrinsic matrix, row-major (px)."""

    header: Header = Header()
    height: int = 0
    width: int = 0
    distortion_model: str = ""
    D: tuple[float, ...] = ()  # noqa: N815 - the ROS field names
    K: tuple[float, ...] = (0.0,) * 9  # noqa: N815
    R: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)  # noqa: N815
    P: tuple[float, ...] = (0.0,) * 12  # noqa: N815
    binning_x: int = 0
    binning_y: int = 0
    roi: RegionOfInterest = RegionOfInterest()


__all__ = ["CameraInfo", "Header", "Image", "Quaternion", "RegionOfInterest", "TFMessage", "Transform",
           "TransformStamped", "Vector3"]
