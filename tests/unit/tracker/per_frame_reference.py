"""Reference: the tracker's per-frame skeleton code as it was before the lean rewrite of the
skeleton path (body dimensions, torso median, hand speed, proximity distance, joints of a
message), on top of the whole-cloud depth reference.

`HeadPipeline` is the tracker pipeline with all of these and the whole-cloud hand search and
object detection (`whole_cloud_reference.ReferencePipeline`): what the tracker computed
before; `tests/unit/tracker/test_per_frame_equivalence.py` compares every output with it.
"""

from __future__ import annotations

from collections import deque
from typing import Literal

import numpy as np

from bus_schema.messages import Skeleton
from handover_model import body as anthropometry
from services.tracker.body import LEG_RATIO, REQUIRED_JOINTS, BodyDimensions
from services.tracker.config import TrackerConfig
from services.tracker.core import TORSO_MEDIAN_FRAMES, SkeletonFrame
from services.tracker.corrections import ProximityFilter
from tests.unit.tracker.whole_cloud_reference import ReferencePipeline


def reference_skeleton_frame_from_message(msg: Skeleton, t_s: float) -> SkeletonFrame:
    """A `SkeletonFrame` with one array per joint."""
    joints: dict[str, np.ndarray] = {j.name: np.asarray(j.position_m, float) for j in msg.joints}
    return SkeletonFrame(tracked=bool(msg.tracked) and bool(joints), joints_m=joints, t_s=t_s)


def _dist(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b))


class ReferenceBodyDimensionEstimator:
    """Running body-dimension estimate (deque of rows, stacked and reduced on every call).

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


class ReferenceProximityFilter(ProximityFilter):
    """The proximity filter with the distance from `np.linalg.norm`."""

    def update(self, t_s: float, estimate_m: np.ndarray, robot_hand_m: np.ndarray | None) -> tuple[np.ndarray, bool]:
        estimate = np.asarray(estimate_m, float)
        distance = np.inf if robot_hand_m is None else float(np.linalg.norm(np.asarray(robot_hand_m, float) - estimate))
        if self.engaged and distance > self.release_m:
            self.engaged = False
        elif not self.engaged and distance < self.engage_m:
            self.engaged = True
            self._held_t, self._held = self._history[-1] if self._history else (t_s, estimate.copy())
            self._velocity = self._estimate_velocity()
        if not self.engaged:
            self._history.append((t_s, estimate.copy()))
            return estimate, False
        assert self._held is not None
        if self.mode == "hold":
            return self._held.copy(), True
        dt = max(0.0, t_s - self._held_t)
        tau = self.time_constant_s
        return self._held + self._velocity * tau * (1.0 - np.exp(-dt / tau)), True


class HeadPipeline(ReferencePipeline):
    """The tracker pipeline as it was: whole-cloud depth processing and the skeleton code above."""

    def __init__(self, config: TrackerConfig, arm_geometry) -> None:
        super().__init__(config, arm_geometry)
        self.body = ReferenceBodyDimensionEstimator(config.floor_z_m, config.body_window_frames)  # type: ignore[assignment]
        self.proximity = ReferenceProximityFilter(
            config.proximity_engage_m, config.proximity_release_m, config.proximity_mode, config.predict_time_constant_s
        )
        self._reference_torso: deque[np.ndarray] = deque(maxlen=TORSO_MEDIAN_FRAMES)

    def on_depth(self, frame) -> None:
        """The detection's cadence as it was: due on every n-th depth frame from the first."""
        self._depth = frame
        self._depth_count += 1
        if (self._depth_count - 1) % self.config.object_every_n_depth_frames == 0:
            self._object_due = True

    def _torso_m(self, frame: SkeletonFrame) -> np.ndarray:
        if "torso" in frame.joints_m:
            self._reference_torso.append(np.asarray(frame.joints_m["torso"], float))
        return np.median(np.array(self._reference_torso), axis=0) if self._reference_torso else np.zeros(3)

    def _lose(self) -> None:
        super()._lose()
        self._reference_torso.clear()

    def _raw_speed(self, now: float, raw: np.ndarray) -> float:
        hist = self._raw_history
        hist.append((now, raw.copy()))
        while len(hist) > 2 and hist[1][0] <= now - self.config.lag_speed_window_s:
            hist.popleft()
        t0, p0 = hist[0]
        if now - t0 < 0.5 * self.config.lag_speed_window_s:
            return 0.0
        return float(np.linalg.norm(raw - p0) / (now - t0))
