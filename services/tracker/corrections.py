"""Mincelli et al.'s corrections of the Kinect hand estimate (thesis §4.1, Fig. 32).

(a) Lag correction: the skeleton lags the real hand by 100–150 ms, so while the receiver
    reaches out, the hand estimate trails behind. The real hand is the part of the person
    nearest the sensor, which faces the receiver: the estimate moves to the closest 3-D point
    of the human's point cloud inside a small box around it.
(b) Robot proximity: when the robot's hand is closer than 15 cm to the human's hand estimate,
    the robot merges into the person's point cloud and drags the estimate; the estimate is
    filtered out (held, or predicted) until they part, assuming the person moves little while
    that close.
Plus the removal of the robot's own points from the cloud using its link geometry.

Pure functions and small state machines; points in the scene's `base` frame, metres.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from handover_model.shapes import Capsule
from services.tracker.lean import vector_norm


def points_in_box(points_m: np.ndarray, centre_m: np.ndarray, half_size_m: float) -> np.ndarray:
    """Boolean mask (N,) of points (N, 3) inside the axis-aligned cube of half edge
    `half_size_m` centred on `centre_m`."""
    return np.all(np.abs(points_m - np.asarray(centre_m, dtype=points_m.dtype)) <= half_size_m, axis=1)


@dataclass(frozen=True)
class LagResult:
    """Outcome of the lag correction.

    Attributes:
        position_m: corrected hand (3,), or the estimate unchanged when `acted` is False.
        acted: a cloud point was found in the box and the estimate moved.
        closest_point_m: the closest cloud point used (None when not acted).
        points_in_box: number of cloud points inside the box.
    """

    position_m: np.ndarray
    acted: bool
    closest_point_m: np.ndarray | None
    points_in_box: int


def lag_correct(
    estimate_m: np.ndarray,
    cloud_m: np.ndarray,
    reference_m: np.ndarray,
    box_half_size_m: float,
    snap_radius_m: float = 0.0,
    surface_offset_m: float = 0.0,
) -> LagResult:
    """Correction (a): move the hand estimate to the cloud point closest to `reference_m`
    inside the box around the estimate.

    Args:
        estimate_m: the tracker's hand estimate (3,).
        cloud_m: the human's point cloud (N, 3), robot points already removed.
        reference_m: what "closest" is measured from (3,): the sensor (Mincelli et al.'s
            Kinect faced the receiver) or the robot's hand the receiver reaches for.
        box_half_size_m: half edge of the search cube.
        snap_radius_m: average the box points within this distance of the closest point
            (0: the single closest point).
        surface_offset_m: move the result this far away from the reference (from the
            surface facing it toward the hand's centre).
    """
    estimate = np.asarray(estimate_m, float)
    cloud = np.asarray(cloud_m).reshape(-1, 3)
    inside = cloud[points_in_box(cloud, estimate, box_half_size_m)] if len(cloud) else cloud
    if len(inside) == 0:
        return LagResult(estimate.copy(), False, None, 0)
    sensor = np.asarray(reference_m, float)
    rng = np.linalg.norm(inside - sensor, axis=1)
    closest = inside[int(np.argmin(rng))].astype(float)
    target = closest
    if snap_radius_m > 0.0:
        near = inside[np.linalg.norm(inside - closest, axis=1) <= snap_radius_m]
        target = near.mean(axis=0).astype(float)
    if surface_offset_m > 0.0:
        ray = target - sensor
        target = target + surface_offset_m * ray / max(np.linalg.norm(ray), 1e-9)
    return LagResult(target, True, closest, int(len(inside)))


def robot_point_mask(points_m: np.ndarray, capsules: list[Capsule], margin_m: float) -> np.ndarray:
    """Boolean mask (N,) of points (N, 3) within `margin_m` of any robot capsule's surface."""
    points = np.asarray(points_m, float).reshape(-1, 3)
    mask = np.zeros(len(points), dtype=bool)
    if len(points) == 0:
        return mask
    points_lo, points_hi = points.min(axis=0), points.max(axis=0)
    for cap in capsules:
        a = np.asarray(cap.a_m, float)
        ba = np.asarray(cap.b_m, float) - a
        reach = cap.radius_m + margin_m
        # Cheap bounding-box rejection before the exact distance: whole capsules first.
        lo = np.minimum(a, a + ba) - reach
        hi = np.maximum(a, a + ba) + reach
        if np.any(lo > points_hi) or np.any(hi < points_lo):
            continue
        cand = np.flatnonzero(~mask & np.all((points >= lo) & (points <= hi), axis=1))
        if len(cand) == 0:
            continue
        pa = points[cand] - a
        baba = float(ba @ ba)
        h = np.clip(pa @ ba / baba, 0.0, 1.0) if baba > 1e-12 else np.zeros(len(cand))
        dist = np.linalg.norm(pa - h[:, None] * ba, axis=1)
        mask[cand[dist <= reach]] = True
    return mask


ProximityMode = Literal["hold", "predict"]


class ProximityFilter:
    """Correction (b): hold (or predict) the hand estimate while the robot's hand is close.

    Engages when |robot hand − estimate| < `engage_m`, releases when it exceeds `release_m`
    (≥ `engage_m`, hysteresis). While engaged the output is the last output before engaging
    (``hold``), or that output moved on with the velocity it had, decaying exponentially with
    `time_constant_s` (``predict``).

    Args:
        engage_m, release_m: thresholds (m).
        mode: ``hold`` or ``predict``.
        time_constant_s: velocity decay for ``predict`` (s).
    """

    def __init__(self, engage_m: float = 0.15, release_m: float = 0.17, mode: ProximityMode = "hold",
                 time_constant_s: float = 0.15) -> None:
        if not 0.0 < engage_m <= release_m:
            raise ValueError("need 0 < engage_m <= release_m")
        self.engage_m = engage_m
        self.release_m = release_m
        self.mode = mode
        self.time_constant_s = time_constant_s
        self.engaged = False
        self._held: np.ndarray | None = None
        self._held_t = 0.0
        self._velocity = np.zeros(3)
        self._history: deque[tuple[float, np.ndarray]] = deque(maxlen=8)

    def reset(self) -> None:
        """Forget everything (e.g. when the person is lost)."""
        self.engaged = False
        self._held = None
        self._history.clear()

    def update(self, t_s: float, estimate_m: np.ndarray, robot_hand_m: np.ndarray | None) -> tuple[np.ndarray, bool]:
        """Filter one estimate.

        Args:
            t_s: time of the estimate (s).
            estimate_m: the hand estimate (3,), before this filter.
            robot_hand_m: the robot's hand (3,), or None when unknown (never engages).

        Returns:
            (output hand position (3,), engaged on this frame).
        """
        estimate = np.asarray(estimate_m, float)
        distance = np.inf if robot_hand_m is None else vector_norm(np.asarray(robot_hand_m, float) - estimate)
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

    def _estimate_velocity(self) -> np.ndarray:
        if len(self._history) < 2:
            return np.zeros(3)
        t = np.array([h[0] for h in self._history])
        p = np.stack([h[1] for h in self._history])
        if t[-1] - t[0] <= 1e-6:
            return np.zeros(3)
        return np.polyfit(t - t[-1], p, 1)[0]
