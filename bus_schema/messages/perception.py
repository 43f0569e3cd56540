"""What the (simulated) Kinect and the tracker see, in the scene's `base` frame (x forward, y left,
z up, m): the skeleton, the depth image, the receiver's state and the object on the table.
"""

from __future__ import annotations

from typing import Annotated, Literal, get_args

import msgspec
from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.types import MAX_PAYLOAD_BYTES, DistanceM, DurationS, Fraction, MassKg, QuaternionXYZW, Vec3M

SkeletonJointName = Literal[
    "head",
    "neck",
    "torso",
    "left_shoulder",
    "left_elbow",
    "left_hand",
    "right_shoulder",
    "right_elbow",
    "right_hand",
    "left_hip",
    "left_knee",
    "left_foot",
    "right_hip",
    "right_knee",
    "right_foot",
]
#: The skeleton's joints in message order (the `SkeletonJointName` literal's order).
SKELETON_JOINTS: tuple[SkeletonJointName, ...] = get_args(SkeletonJointName)


class SkeletonJoint(msgspec.Struct, frozen=True, kw_only=True):
    """One tracked joint: OpenNI name, position in the `base` frame (m), confidence 0..1."""

    name: SkeletonJointName
    position_m: Vec3M
    confidence: Fraction = 1.0


class Skeleton(Message, frozen=True, kw_only=True):
    """OpenNI-style 15-joint skeleton from the (simulated) Kinect, 30 Hz.

    Attributes:
        tracked: a person is tracked; `joints` is empty when not.
        user_id: tracker's id of the person.
        joints: up to 15 joints, positions in the `base` frame.
    """

    tracked: bool
    user_id: Annotated[int, Meta(ge=0, le=65535)] = 0
    joints: Annotated[list[SkeletonJoint], Meta(max_length=len(SKELETON_JOINTS))] = []


class DepthImage(Message, frozen=True, kw_only=True):
    """Depth image from the (simulated) Kinect, 30 Hz.

    Attributes:
        width, height: image size in pixels.
        depth_mm: row-major little-endian uint16 depths in millimetres (0 = no reading);
            exactly ``2 * width * height`` bytes.
        fx, fy, cx, cy: pinhole intrinsics in pixels.
        camera_position_m, camera_orientation_xyzw: pose of the optical frame (z forward,
            x right, y down) in the `base` frame.
    """

    width: Annotated[int, Meta(ge=1, le=1024)]
    height: Annotated[int, Meta(ge=1, le=1024)]
    depth_mm: Annotated[bytes, Meta(max_length=MAX_PAYLOAD_BYTES - 4096)]
    fx: Annotated[float, Meta(gt=0.0, le=1e5)]
    fy: Annotated[float, Meta(gt=0.0, le=1e5)]
    cx: Annotated[float, Meta(ge=-1e5, le=1e5)]
    cy: Annotated[float, Meta(ge=-1e5, le=1e5)]
    camera_position_m: Vec3M = (0.0, 0.0, 0.0)
    camera_orientation_xyzw: QuaternionXYZW = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if len(self.depth_mm) != 2 * self.width * self.height:
            raise ValueError(
                f"depth_mm has {len(self.depth_mm)} bytes, expected 2*width*height = "
                f"{2 * self.width * self.height}"
            )


Posture = Literal["standing", "sitting", "unknown"]
HandCorrection = Literal["none", "lag", "proximity_hold", "lag+proximity_hold"]


class HumanState(Message, frozen=True, kw_only=True):
    """Receiver state from the tracker (corrected hand, body dimensions), `base` frame.

    Attributes:
        tracked: a person is tracked; the other fields are meaningless when False.
        hand_position_m: corrected hand position (the hand that receives).
        hand_raw_position_m: the tracker's hand estimate before correction.
        correction: which correction acted on this frame.
        torso_position_m: torso joint position.
        height_m, arm_span_m, shoulder_height_m: body dimensions estimated over frames.
        posture: standing or sitting.
        weight_kg: body weight from the receiver's profile (a camera cannot weigh).
        frame_age_s: age of the skeleton frame this state comes from, s (local clock).
    """

    tracked: bool
    hand_position_m: Vec3M = (0.0, 0.0, 0.0)
    hand_raw_position_m: Vec3M = (0.0, 0.0, 0.0)
    correction: HandCorrection = "none"
    torso_position_m: Vec3M = (0.0, 0.0, 0.0)
    height_m: Annotated[float, Meta(ge=0.0, le=3.0)] = 0.0
    arm_span_m: Annotated[float, Meta(ge=0.0, le=3.5)] = 0.0
    shoulder_height_m: Annotated[float, Meta(ge=0.0, le=3.0)] = 0.0
    posture: Posture = "unknown"
    weight_kg: Annotated[float, Meta(ge=0.0, le=400.0)] = 0.0
    frame_age_s: DurationS = 0.0


class ObjectEstimate(Message, frozen=True, kw_only=True):
    """Object found on the table from depth (`base` frame).

    Attributes:
        found: an object was found.
        position_m: centre of the object.
        size_m: bounding-box extents (x, y, z).
        mass_kg: mass from the task description (a camera cannot weigh).
    """

    found: bool
    position_m: Vec3M = (0.0, 0.0, 0.0)
    size_m: tuple[DistanceM, DistanceM, DistanceM] = (0.0, 0.0, 0.0)
    mass_kg: MassKg = 0.0
