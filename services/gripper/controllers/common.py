"""What every release controller shares: the force limit, the default periods and
thresholds, the checks of parameters and sensor fields, the controller-side mode estimate,
and the base class that keeps the batch size and the mode per episode.

Frames and units (thesis Fig. 15, DESIGN §5): gripper frame, x along the pull toward the
receiver, y DOWN; forces in N, accelerations in m/s² (a_y > 0: object falling), times in s.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from handover_model.grip import GripController, Mode, SensorSample
from services.gripper.errors import GripperError

#: ISO/TS 15066 quasi-static limit for the hand, N: no controller may command more.
ABSOLUTE_MAX_GRIP_FORCE_N = 140.0
#: Default control period, s (the thesis's force sensor rate, 100 Hz).
DEFAULT_PERIOD_S = 0.01
#: |a_y| above which a controller reports SLIP rather than GRASP, m/s².
DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2 = 0.5
#: Slip speed above which a controller reports SLIP (when the optical sensor sees the
#: object), m/s.
DEFAULT_SLIP_SPEED_THRESHOLD_M_S = 0.005


def check_finite(name: str, value: float, *, positive: bool = False, nonneg: bool = False) -> None:
    """Raise GripperError unless parameter `name` is finite (and > 0 or >= 0 when asked)."""
    if not math.isfinite(value):
        raise GripperError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0.0:
        raise GripperError(f"{name} must be > 0, got {value!r}")
    if nonneg and value < 0.0:
        raise GripperError(f"{name} must be >= 0, got {value!r}")


def check_max_force(max_grip_force_n: float) -> None:
    """Raise GripperError unless a force clamp (N) is positive and within the hand limit."""
    check_finite("max_grip_force_n", max_grip_force_n, positive=True)
    if max_grip_force_n > ABSOLUTE_MAX_GRIP_FORCE_N:
        raise GripperError(
            f"max_grip_force_n = {max_grip_force_n} N exceeds the {ABSOLUTE_MAX_GRIP_FORCE_N} N "
            "hand pinch limit (ISO/TS 15066); lower it"
        )


def as_episodes(values, n_episodes: int, name: str) -> np.ndarray:
    """Broadcast a sensor field to shape (n_episodes,), float64."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim == 0:
        return np.full(n_episodes, float(arr))
    if arr.shape != (n_episodes,):
        raise GripperError(
            f"sensor field {name} has shape {arr.shape}, expected ({n_episodes},): "
            "call reset(n_episodes) with the batch size of the samples"
        )
    return arr


def estimate_mode(
    grip_force_n: np.ndarray,
    sample: SensorSample,
    n_episodes: int,
    slip_accel_threshold_m_s2: float,
    slip_speed_threshold_m_s: float,
) -> np.ndarray:
    """Controller-side mode estimate: RELEASE where the command is zero, SLIP where the
    optical sensor sees the object move (|a_y| or slip speed above threshold), else GRASP."""
    accel = np.abs(as_episodes(sample.accel_y_m_s2, n_episodes, "accel_y_m_s2"))
    speed = np.hypot(
        as_episodes(sample.slip_velocity_x_m_s, n_episodes, "slip_velocity_x_m_s"),
        as_episodes(sample.slip_velocity_y_m_s, n_episodes, "slip_velocity_y_m_s"),
    )
    valid = np.broadcast_to(np.asarray(sample.optical_valid, dtype=bool), (n_episodes,))
    moving = (accel > slip_accel_threshold_m_s2) | (valid & (speed > slip_speed_threshold_m_s))
    mode = np.where(moving, int(Mode.SLIP), int(Mode.GRASP))
    return np.where(grip_force_n <= 0.0, int(Mode.RELEASE), mode).astype(np.int8)


class ModeReportingController(GripController, Protocol):
    """A `GripController` that also keeps its mode estimate per episode (`Mode` codes, int8),
    as every controller of `registry` does: the gripper service publishes it."""

    mode: np.ndarray


class BaseController:
    """Shared plumbing: period, batch size, mode estimate."""

    period_s: float

    def __init__(self, period_s: float) -> None:
        check_finite("period_s", period_s, positive=True)
        self.period_s = float(period_s)
        self.n_episodes = 0
        self.mode = np.zeros(0, dtype=np.int8)
        self.grip_force_n = np.zeros(0)

    def _require_reset(self, sample: SensorSample) -> None:
        if self.n_episodes == 0:
            raise GripperError(f"{type(self).__name__}.step called before reset(n_episodes)")
        n = sample.n_episodes
        if np.ndim(sample.force_x_n) != 0 and n != self.n_episodes:
            raise GripperError(
                f"sample carries {n} episodes but the controller was reset for {self.n_episodes}"
            )

    def _reset_common(self, n_episodes: int) -> None:
        if int(n_episodes) < 1:
            raise GripperError(f"n_episodes must be >= 1, got {n_episodes!r}")
        self.n_episodes = int(n_episodes)
        self.mode = np.full(self.n_episodes, int(Mode.GRASP), dtype=np.int8)
