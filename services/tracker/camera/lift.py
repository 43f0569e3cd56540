"""A person's 2-D landmarks + depth → the 15 OpenNI joints in `base` (pure: no I/O).

Joints from MediaPipe's landmarks (pixel positions averaged, visibility the smallest):

- ``head``: the ears' midpoint (the nose when the ears are hidden); ``neck``: the shoulders'
  midpoint; ``torso``: halfway between the shoulders' and the hips' midpoints (with the hips
  out of view: 0.6 shoulder widths below the neck, in the image);
- shoulders, elbows, hips, knees as they are; ``*_hand``: the wrist, index and pinky
  knuckles' mean (OpenNI's hand joint is the palm); ``*_foot``: the ankle.

Depth at a joint: the median of the non-zero depths within `DEPTH_WINDOW_PX` of its pixel;
with none there (a hole, or the pixel outside the image) the person's median shoulder depth.
Without a depth image (a webcam) the whole person is put at the distance at which their
shoulders, ``shoulder_width_m`` apart, look as wide as they do (``fx · width / pixels``): a
flat person, good to a few centimetres only while they face the camera.
Back-projection: pinhole (`Intrinsics`) into the optical frame (z forward, x right, y down),
then the calibration (`CameraPose`) into `base`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bus_schema.messages import SKELETON_JOINTS
from services.tracker.camera.capture import Intrinsics
from services.tracker.camera.pose2d import Person2D
from services.tracker.ros1.calibration import CameraPose

DEPTH_WINDOW_PX = 4
#: The torso pixel below the neck, in shoulder widths, when the hips are out of view.
TORSO_BELOW_NECK = 0.6
#: Depths outside this range are not readings, m.
MIN_DEPTH_M, MAX_DEPTH_M = 0.2, 10.0

_SIMPLE = {"left_shoulder": ("left_shoulder",), "right_shoulder": ("right_shoulder",),
           "left_elbow": ("left_elbow",), "right_elbow": ("right_elbow",),
           "left_hand": ("left_wrist", "left_index", "left_pinky"),
           "right_hand": ("right_wrist", "right_index", "right_pinky"),
           "left_hip": ("left_hip",), "right_hip": ("right_hip",), "left_knee": ("left_knee",),
           "right_knee": ("right_knee",), "left_foot": ("left_ankle",), "right_foot": ("right_ankle",),
           "neck": ("left_shoulder", "right_shoulder")}


@dataclass(frozen=True)
class Person3D:
    """One person's joints in `base`.

    Attributes:
        joints_m: joint name → (3,) position, m, for the joints seen well enough.
        confidence: joint name → visibility 0..1.
        torso_m: (3,) the torso (or, hidden, the neck) in `base`, m: where the person stands.
        pixels: joint name → (2,) pixel position (for figures and checks).
    """

    joints_m: dict[str, np.ndarray]
    confidence: dict[str, float]
    torso_m: np.ndarray
    pixels: dict[str, np.ndarray]


def joint_pixels(person: Person2D) -> dict[str, tuple[np.ndarray, float]]:
    """Each OpenNI joint's pixel (2,) and visibility (see the module docstring)."""
    out: dict[str, tuple[np.ndarray, float]] = {}
    for joint, names in _SIMPLE.items():
        pts = [person.point(n) for n in names]
        out[joint] = (np.mean([p for p, _ in pts], axis=0), min(v for _, v in pts))
    ears = [person.point("left_ear"), person.point("right_ear")]
    nose = person.point("nose")
    out["head"] = (np.mean([p for p, _ in ears], axis=0), min(v for _, v in ears))
    if out["head"][1] < nose[1]:
        out["head"] = nose
    neck, neck_vis = out["neck"]
    hips = [person.point("left_hip"), person.point("right_hip")]
    hip_vis = min(v for _, v in hips)
    if hip_vis >= neck_vis * 0.5 and hip_vis >= 0.5:
        out["torso"] = (0.5 * (neck + np.mean([p for p, _ in hips], axis=0)), min(neck_vis, hip_vis))
    else:
        out["torso"] = (neck + np.array([0.0, TORSO_BELOW_NECK * person.shoulder_width_px]), neck_vis)
    return out


def depth_at(depth_mm: np.ndarray, pixel: np.ndarray) -> float | None:
    """The median valid depth (m) within `DEPTH_WINDOW_PX` of `pixel`, or None."""
    h, w = depth_mm.shape
    u, v = int(round(float(pixel[0]))), int(round(float(pixel[1])))
    if not (0 <= u < w and 0 <= v < h):
        return None
    r = DEPTH_WINDOW_PX
    patch = depth_mm[max(0, v - r):v + r + 1, max(0, u - r):u + r + 1].astype(float) / 1000.0
    valid = patch[(patch >= MIN_DEPTH_M) & (patch <= MAX_DEPTH_M)]
    return float(np.median(valid)) if valid.size else None


def lift_person(person: Person2D, intrinsics: Intrinsics, pose: CameraPose, depth_mm: np.ndarray | None,
                min_visibility: float, shoulder_width_m: float) -> Person3D | None:
    """`person`'s joints in `base` (see the module docstring); None when neither depth nor the
    shoulders give a distance."""
    pix = joint_pixels(person)
    if depth_mm is not None:
        shoulder_depths = [d for d in (depth_at(depth_mm, pix[s][0]) for s in ("left_shoulder", "right_shoulder"))
                           if d is not None]
        fallback = float(np.median(shoulder_depths)) if shoulder_depths else None
    else:
        width_px = person.shoulder_width_px
        fallback = intrinsics.fx * shoulder_width_m / width_px if width_px >= 4.0 else None
    if fallback is None or not MIN_DEPTH_M <= fallback <= MAX_DEPTH_M:
        return None
    rotation, origin = pose.optical_rotation, pose.position_m

    def to_base(pixel: np.ndarray) -> np.ndarray:
        z = (depth_at(depth_mm, pixel) if depth_mm is not None else None) or fallback
        optical = np.array([(pixel[0] - intrinsics.cx) / intrinsics.fx * z,
                            (pixel[1] - intrinsics.cy) / intrinsics.fy * z, z])
        return rotation @ optical + origin

    joints: dict[str, np.ndarray] = {}
    confidence: dict[str, float] = {}
    for name in SKELETON_JOINTS:
        pixel, vis = pix[name]
        if vis >= min_visibility:
            joints[name] = to_base(pixel)
            confidence[name] = vis
    torso = joints.get("torso", joints.get("neck"))
    if torso is None:
        torso = to_base(pix["neck"][0])
    return Person3D(joints, confidence, torso, {k: v[0] for k, v in pix.items()})
