"""Body dimensions from the skeleton, robust over frames (medians over a window).

Model (the stack's one anthropometric table, `handover_model.body`: Drillis & Contini segment
ratios of the standing height H, arms scaled so the arm span equals H):
- posture: standing when the thighs are closer to vertical than to horizontal
  ((hip z − knee z) / thigh length > 0.5), sitting otherwise;
- height H: standing, from the head joint's height above the floor, H = h_head / 0.930;
  sitting, from the leg lengths, H = (thigh + shank) / 0.491, each segment corrected for the
  lengthening that joint noise causes (≈ var(length) / length), averaged with the trunk
  estimate H = (shoulder z − hip z) / 0.288;
- shoulder height: mean height of the shoulder joints above the floor (in the current
  posture);
- arm span: shoulder-joint distance + both arms' (upper arm + forearm) + 2 × 0.047 H
  (hand joint to fingertip, which the skeleton cannot see);
- weight: not measurable by a camera; it comes from the receiver's profile.
Per-frame values are kept for the last `window` frames and the estimate is their median, so
jitter of 50–100 mm per joint averages down and single bad frames do not matter.

Per frame: the nine segment lengths come from one `row_norms` call (numpy's vector norm, bit
for bit), the window is a `RowWindow` (no stacking of 90 rows), and the estimate is kept
until the window changes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from handover_model import body as anthropometry
from services.tracker.lean import RowWindow, median_rows, row_norms

REQUIRED_JOINTS = (
    "head", "left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_hand",
    "right_hand", "left_hip", "right_hip", "left_knee", "right_knee", "left_foot", "right_foot",
)
LEG_RATIO = anthropometry.HIP_HEIGHT_FRACTION - anthropometry.ANKLE_HEIGHT_FRACTION  # thigh + shank
_J = {name: i for i, name in enumerate(REQUIRED_JOINTS)}
#: Segments (from, to) as rows of the stacked joints: thighs, shanks, upper arms and forearms
#: (left, right), then shoulder to shoulder.
_SEGMENTS = np.array([[_J[f"{s}_{a}"], _J[f"{s}_{b}"]] for a, b in (("hip", "knee"), ("knee", "foot"))
                      for s in ("left", "right")]
                     + [[_J[f"{s}_{a}"], _J[f"{s}_{b}"]] for s in ("left", "right")
                        for a, b in (("shoulder", "elbow"), ("elbow", "hand"))]
                     + [[_J["left_shoulder"], _J["right_shoulder"]]])


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


class BodyDimensionEstimator:
    """Running body-dimension estimate.

    Args:
        floor_z_m: floor height in `base` (m).
        window: number of recent frames the medians use.
    """

    def __init__(self, floor_z_m: float, window: int = 90) -> None:
        self.floor_z_m = floor_z_m
        self._rows = RowWindow(window, 7)
        self._estimate: BodyDimensions | None = BodyDimensions()  # of the rows as they are

    def reset(self) -> None:
        """Forget all frames (a new person)."""
        self._rows.clear()
        self._estimate = BodyDimensions()

    def update(self, joints_m: dict[str, np.ndarray]) -> bool:
        """Add one skeleton frame (joint name → (3,) position, `base`).

        Returns:
            False when a needed joint is missing (the frame is ignored).
        """
        if any(name not in joints_m for name in REQUIRED_JOINTS):
            return False
        p = np.array([joints_m[name] for name in REQUIRED_JOINTS], dtype=float)
        thigh_l, thigh_r, shank_l, shank_r, upper_l, fore_l, upper_r, fore_r, shoulders = (
            row_norms(p[_SEGMENTS[:, 0]] - p[_SEGMENTS[:, 1]]).tolist())
        z = p[:, 2].tolist()
        j = _J
        floor = self.floor_z_m
        vertical_l = (z[j["left_hip"]] - z[j["left_knee"]]) / max(thigh_l, 1e-3)
        vertical_r = (z[j["right_hip"]] - z[j["right_knee"]]) / max(thigh_r, 1e-3)
        # np.mean of a pair, per row (the same sum and division as three np.mean calls).
        means = np.mean([[thigh_l, thigh_r], [shank_l, shank_r], [vertical_l, vertical_r]], axis=1).tolist()
        arms = (upper_l + fore_l) + (upper_r + fore_r)
        shoulder_sum = z[j["left_shoulder"]] + z[j["right_shoulder"]]
        row = np.array(
            [
                z[j["head"]] - floor,
                means[0],
                means[1],
                0.5 * shoulder_sum - floor,
                shoulders + arms,
                means[2],
                0.5 * (shoulder_sum - z[j["left_hip"]] - z[j["right_hip"]]),
            ]
        )
        if np.all(np.isfinite(row)):
            self._rows.append(row)
            self._estimate = None
            return True
        return False

    def estimate(self) -> BodyDimensions:
        """Current estimate (medians over the window); computed once per change of the window."""
        if self._estimate is None:
            self._estimate = self._compute()
        return self._estimate

    def _compute(self) -> BodyDimensions:
        if not len(self._rows):
            return BodyDimensions()
        rows = self._rows.rows()  # oldest first, as np.stack of the frames' rows
        m = median_rows(rows)
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
            height = head_h / anthropometry.HEAD_JOINT_HEIGHT_FRACTION
        else:
            trunk_ratio = anthropometry.SHOULDER_HEIGHT_FRACTION - anthropometry.HIP_HEIGHT_FRACTION
            height = 0.5 * (legs / LEG_RATIO + trunk / trunk_ratio)
        arm_span = span_no_hands + 2.0 * anthropometry.AVERAGE_UPPER_LIMB.palm_centre_to_fingertip_m * height
        return BodyDimensions(
            height_m=float(np.clip(height, 0.0, 3.0)),
            arm_span_m=float(np.clip(arm_span, 0.0, 3.5)),
            shoulder_height_m=float(np.clip(shoulder_h, 0.0, 3.0)),
            posture=posture,
            frames=len(self._rows),
        )
