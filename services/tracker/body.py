"""Body dimensions from the skeleton, robust over frames (medians over a window).

Model (the anthropometric table of `robot_sim.kinect.receiver`: Drillis & Contini segment
ratios of the standing height H, arms scaled so the arm span equals H):
- posture: standing when the thighs are closer to vertical than to horizontal
  ((hip z − knee z) / thigh length > 0.5), sitting otherwise;
- height H: standing, from the head joint's height above the floor, H = h_head / 0.930;
  sitting, from the leg lengths, H = (thigh + shank) / 0.491, each segment corrected for the
  lengthening that joint noise causes (≈ var(length) / length), averaged with the trunk
  estimate H = (shoulder z − hip z) / 0.288;
- shoulder height: mean height of the shoulder joints above the floor (in the current
  posture);
- arm span: shoulder-joint distance + both arms' (upper arm + forearm) + 2 × 0.040 H
  (hand joint to fingertip, which the skeleton cannot see);
- weight: not measurable by a camera; it comes from the receiver's profile.
Per-frame values are kept for the last `window` frames and the estimate is their median, so
jitter of 50–100 mm per joint averages down and single bad frames do not matter.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robot_sim.kinect import receiver as anthropometry

REQUIRED_JOINTS = (
    "head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_hand",
    "right_hand", "left_hip", "right_hip", "left_knee", "right_knee", "left_foot", "right_foot",
)
LEG_RATIO = anthropometry.THIGH_RATIO + anthropometry.SHANK_RATIO


@dataclass(frozen=True)
class BodyDimensions:
    """Estimated body (metres); zeros and ``unknown`` until a frame has been seen.

    Attributes:
        height_m, arm_span_m, shoulder_height_m: as in `HumanState`.
        posture: standing, sitting or unknown.
        frames: number of frames the estimate is based on.
    """

    height_m: float = 0.0
    arm_span_m: float = 0.0
    shoulder_height_m: float = 0.0
    posture: Literal["standing", "sitting", "unknown"] = "unknown"
    frames: int = 0


def _dist(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b))


class BodyDimensionEstimator:
    """Running body-dimension estimate.

    Args:
        floor_z_m: floor height in `base` (m).
        window: number of recent frames the medians use.
    """

    def __init__(self, floor_z_m: float, window: int = 90) -> None:
        self.floor_z_m = floor_z_m
        self._rows: deque[np.ndarray] = deque(maxlen=window)

    def reset(self) -> None:
        """Forget all frames (a new person)."""
        self._rows.clear()

    def update(self, joints_m: dict[str, np.ndarray]) -> bool:
        """Add one skeleton frame (joint name → (3,) position, `base`).

        Returns:
            False when a needed joint is missing (the frame is ignored).
        """
        if any(name not in joints_m for name in REQUIRED_JOINTS):
            return False
        j = {k: np.asarray(v, float) for k, v in joints_m.items()}
        floor = self.floor_z_m
        thighs = [_dist(j[f"{s}_hip"], j[f"{s}_knee"]) for s in ("left", "right")]
        shanks = [_dist(j[f"{s}_knee"], j[f"{s}_foot"]) for s in ("left", "right")]
        vertical = [
            (j[f"{s}_hip"][2] - j[f"{s}_knee"][2]) / max(t, 1e-3) for s, t in zip(("left", "right"), thighs)
        ]
        arms = sum(
            _dist(j[f"{s}_shoulder"], j[f"{s}_elbow"]) + _dist(j[f"{s}_elbow"], j[f"{s}_hand"])
            for s in ("left", "right")
        )
        row = np.array(
            [
                j["head"][2] - floor,
                float(np.mean(thighs)),
                float(np.mean(shanks)),
                0.5 * (j["left_shoulder"][2] + j["right_shoulder"][2]) - floor,
                _dist(j["left_shoulder"], j["right_shoulder"]) + arms,
                float(np.mean(vertical)),
                0.5 * (j["left_shoulder"][2] + j["right_shoulder"][2] - j["left_hip"][2] - j["right_hip"][2]),
            ]
        )
        if np.all(np.isfinite(row)):
            self._rows.append(row)
            return True
        return False

    def estimate(self) -> BodyDimensions:
        """Current estimate (medians over the window)."""
        if not self._rows:
            return BodyDimensions()
        rows = np.stack(self._rows)
        m = np.median(rows, axis=0)
        head_h, thigh, shank, shoulder_h, span_no_hands, vertical, trunk = (float(v) for v in m)
        # Joint noise lengthens a segment on average by about var(length)/length (the
        # perpendicular noise adds in quadrature); each column is the mean of two sides,
        # whose variance is half a single side's.
        if len(rows) >= 10:
            thigh -= 2.0 * float(np.var(rows[:, 1])) / max(thigh, 1e-3)
            shank -= 2.0 * float(np.var(rows[:, 2])) / max(shank, 1e-3)
        legs = thigh + shank
        posture: Literal["standing", "sitting"] = "standing" if vertical > 0.5 else "sitting"
        if posture == "standing":
            height = head_h / anthropometry.HEAD_CENTRE_HEIGHT_RATIO
        else:
            trunk_ratio = anthropometry.SHOULDER_HEIGHT_RATIO - anthropometry.HIP_HEIGHT_RATIO
            height = 0.5 * (legs / LEG_RATIO + trunk / trunk_ratio)
        arm_span = span_no_hands + 2.0 * anthropometry.HAND_TIP_RATIO * height
        return BodyDimensions(
            height_m=float(np.clip(height, 0.0, 3.0)),
            arm_span_m=float(np.clip(arm_span, 0.0, 3.5)),
            shoulder_height_m=float(np.clip(shoulder_h, 0.0, 3.0)),
            posture=posture,
            frames=len(self._rows),
        )
