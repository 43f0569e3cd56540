"""Chan et al.'s human-inspired release controller (HI, thesis eq 3.22, Fig. 25):
F_G = m F_L + F_ZLG, forces in N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handover_model.grip import SensorSample
from services.gripper.controllers.common import (
    ABSOLUTE_MAX_GRIP_FORCE_N,
    DEFAULT_PERIOD_S,
    DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2,
    DEFAULT_SLIP_SPEED_THRESHOLD_M_S,
    BaseController,
    as_episodes,
    check_finite,
    check_max_force,
    estimate_mode,
)
from services.gripper.errors import GripperError


@dataclass(frozen=True)
class HumanInspiredParams:
    """Chan et al.'s human-inspired law (eq 3.22, thesis Fig. 25), as set in §3.6.1.1.

    F_G = m F_L + F_ZLG for load F_L ≥ 0, with the slope m = (F_Go − F_ZLG) / F_Lo so that
    the initial load F_Lo gets the initial grip F_Go. Between ε and zero load the grip stays
    at the safety margin F_ZLG; once the load reaches ε (the receiver lifts the object by
    |ε| beyond its weight) the gripper opens, F_G = 0, and stays open (`latch_release`).

    Attributes:
        initial_grip_force_n: F_Go, N (thesis: 15 N).
        release_load_n: ε, N, the load at which the object is released (thesis: −2 N).
        zero_load_grip_force_n: F_ZLG, N (thesis: 5 N).
        initial_load_n: F_Lo, N; None takes the vertical load F_sy of the first sample.
        latch_release: once released, stay released for the rest of the episode.
        max_grip_force_n: clamp, N (≤ 140 N).
    """

    initial_grip_force_n: float = 15.0
    release_load_n: float = -2.0
    zero_load_grip_force_n: float = 5.0
    initial_load_n: float | None = None
    latch_release: bool = True
    max_grip_force_n: float = ABSOLUTE_MAX_GRIP_FORCE_N

    def __post_init__(self) -> None:
        check_finite("initial_grip_force_n", self.initial_grip_force_n, positive=True)
        check_finite("zero_load_grip_force_n", self.zero_load_grip_force_n, nonneg=True)
        check_finite("release_load_n", self.release_load_n)
        if self.release_load_n > 0.0:
            raise GripperError(
                f"release_load_n (ε) must be <= 0 N (an upward pull beyond the weight), got {self.release_load_n}"
            )
        if self.zero_load_grip_force_n >= self.initial_grip_force_n:
            raise GripperError("zero_load_grip_force_n (F_ZLG) must be below initial_grip_force_n (F_Go)")
        if self.initial_load_n is not None:
            check_finite("initial_load_n", self.initial_load_n, positive=True)
        check_max_force(self.max_grip_force_n)


def human_inspired_grip_n(params: HumanInspiredParams, load_n, initial_load_n):
    """Grip force (N) of eq 3.22 for vertical load(s) F_L (N) given F_Lo (N), without latching."""
    load = np.asarray(load_n, dtype=float)
    f_lo = np.asarray(initial_load_n, dtype=float)
    if np.any(f_lo <= 0.0):
        raise GripperError("initial load F_Lo must be > 0 N: the gripper must hold the object's weight")
    slope = (params.initial_grip_force_n - params.zero_load_grip_force_n) / f_lo
    grip = np.where(
        load >= 0.0,
        slope * load + params.zero_load_grip_force_n,
        np.where(load > params.release_load_n, params.zero_load_grip_force_n, 0.0),
    )
    return np.clip(grip, 0.0, params.max_grip_force_n)


class HumanInspiredController(BaseController):
    """Chan et al.'s human-inspired controller (HI), vectorised over episodes."""

    def __init__(
        self,
        params: HumanInspiredParams | None = None,
        period_s: float = DEFAULT_PERIOD_S,
        slip_accel_threshold_m_s2: float = DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2,
        slip_speed_threshold_m_s: float = DEFAULT_SLIP_SPEED_THRESHOLD_M_S,
    ) -> None:
        super().__init__(period_s)
        self.params = params or HumanInspiredParams()
        self.slip_accel_threshold_m_s2 = slip_accel_threshold_m_s2
        self.slip_speed_threshold_m_s = slip_speed_threshold_m_s

    def reset(self, n_episodes: int = 1) -> None:
        self._reset_common(n_episodes)
        self.grip_force_n = np.full(self.n_episodes, self.params.initial_grip_force_n)
        self.released = np.zeros(self.n_episodes, dtype=bool)
        lo = self.params.initial_load_n
        self.initial_load_n = None if lo is None else np.full(self.n_episodes, lo)

    def step(self, sample: SensorSample) -> np.ndarray:
        self._require_reset(sample)
        n = self.n_episodes
        load = as_episodes(sample.force_y_n, n, "force_y_n")
        if self.initial_load_n is None:
            if np.any(load <= 0.0):
                raise GripperError(
                    "HI controller: the first sample shows no downward load (F_sy <= 0); "
                    "set initial_load_n (F_Lo) or start while the gripper holds the object"
                )
            self.initial_load_n = load.copy()
        grip = human_inspired_grip_n(self.params, load, self.initial_load_n)
        if self.params.latch_release:
            self.released |= grip <= 0.0
            grip = np.where(self.released, 0.0, grip)
        self.grip_force_n = grip
        self.mode = estimate_mode(
            grip, sample, n, self.slip_accel_threshold_m_s2, self.slip_speed_threshold_m_s
        )
        return grip.copy()
