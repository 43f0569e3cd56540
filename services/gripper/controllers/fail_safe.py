"""The thesis's fail-safe release controller (FS, eq 3.19) and its parameter presets.

    F_G[n+1] = k_i (α F_sy[n] + β a_y[n] − γ F_sx[n] − F_margin) + (1 − k_i) F_G[n],

clamped to [0, F_max]: forces in N, a_y in m/s² (down +). Presets FS1/FS2/FS3 (§3.6.1.1) and
the §3.5 simulation set with γ = 1 (Table IV as printed) or γ = 5 (the text of §3.5).
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
class FailSafeParams:
    """Parameters of the fail-safe law (eq 3.19).

    Attributes:
        alpha: gain on the downward wrist force F_sy (dimensionless).
        beta: gain on the downward object acceleration a_y, N/(m/s²) = kg.
        gamma: gain on the pull force F_sx (dimensionless).
        f_margin_n: F_margin, N; tolerated downward acceleration is F_margin/β (eq 3.11).
        k_i: integrator weight per control step (0 < k_i ≤ 1; 1 is eq 3.8 without integrator).
        max_grip_force_n: clamp F_max, N (≤ 140 N).
        initial_grip_force_n: F_G[0], N; None starts at the law's rest value for the first
            sample (α F_sy − γ F_sx − F_margin with a_y ignored), i.e. at its fixed point.
    """

    alpha: float = 10.0
    beta: float = 3.0
    gamma: float = 3.0
    f_margin_n: float = 15.0
    k_i: float = 0.13
    max_grip_force_n: float = ABSOLUTE_MAX_GRIP_FORCE_N
    initial_grip_force_n: float | None = None

    def __post_init__(self) -> None:
        for name in ("alpha", "beta", "gamma", "f_margin_n"):
            check_finite(name, getattr(self, name), nonneg=True)
        check_finite("k_i", self.k_i, positive=True)
        if self.k_i > 1.0:
            raise GripperError(f"k_i must be in (0, 1], got {self.k_i}")
        check_max_force(self.max_grip_force_n)
        if self.initial_grip_force_n is not None:
            check_finite("initial_grip_force_n", self.initial_grip_force_n, nonneg=True)

    def law_target_n(self, force_x_n, force_y_n, accel_y_m_s2):
        """The proportional part α F_sy + β a_y − γ F_sx − F_margin (eq 3.7/3.8), N."""
        return (
            self.alpha * np.asarray(force_y_n, dtype=float)
            + self.beta * np.asarray(accel_y_m_s2, dtype=float)
            - self.gamma * np.asarray(force_x_n, dtype=float)
            - self.f_margin_n
        )


#: §3.6.1.1: FS1 (α=10, β=3, γ=3, F_margin=15 N, k_i=0.13); FS2 is FS1 with α=15; FS3 is
#: FS1 with γ=1. §3.5: α=10, β=3, F_margin=12 N, k_i=0.13, with γ=1 as printed in Table IV
#: ("FS-sim-g1") or γ=5 as stated in the text of §3.5 ("FS-sim-g5").
FS_PRESETS: dict[str, FailSafeParams] = {
    "FS1": FailSafeParams(alpha=10.0, beta=3.0, gamma=3.0, f_margin_n=15.0, k_i=0.13),
    "FS2": FailSafeParams(alpha=15.0, beta=3.0, gamma=3.0, f_margin_n=15.0, k_i=0.13),
    "FS3": FailSafeParams(alpha=10.0, beta=3.0, gamma=1.0, f_margin_n=15.0, k_i=0.13),
    "FS-sim-g1": FailSafeParams(alpha=10.0, beta=3.0, gamma=1.0, f_margin_n=12.0, k_i=0.13),
    "FS-sim-g5": FailSafeParams(alpha=10.0, beta=3.0, gamma=5.0, f_margin_n=12.0, k_i=0.13),
}


def fail_safe_law(params: FailSafeParams, force_x_n, force_y_n, accel_y_m_s2, grip_force_n):
    """One step of eq 3.19, clamped to [0, F_max]: returns F_G[n+1] in N.

    Arguments are F_sx[n], F_sy[n] (N), a_y[n] (m/s², down +) and F_G[n] (N), scalars or
    arrays that broadcast together.
    """
    target = params.law_target_n(force_x_n, force_y_n, accel_y_m_s2)
    raw = params.k_i * target + (1.0 - params.k_i) * np.asarray(grip_force_n, dtype=float)
    return np.clip(raw, 0.0, params.max_grip_force_n)


class FailSafeController(BaseController):
    """The thesis's fail-safe controller (eq 3.19), vectorised over episodes."""

    def __init__(
        self,
        params: FailSafeParams,
        period_s: float = DEFAULT_PERIOD_S,
        slip_accel_threshold_m_s2: float = DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2,
        slip_speed_threshold_m_s: float = DEFAULT_SLIP_SPEED_THRESHOLD_M_S,
    ) -> None:
        super().__init__(period_s)
        self.params = params
        self.slip_accel_threshold_m_s2 = slip_accel_threshold_m_s2
        self.slip_speed_threshold_m_s = slip_speed_threshold_m_s
        self._started = False

    def reset(self, n_episodes: int = 1) -> None:
        self._reset_common(n_episodes)
        initial = self.params.initial_grip_force_n
        self.grip_force_n = np.full(self.n_episodes, 0.0 if initial is None else initial)
        self._started = initial is not None

    def step(self, sample: SensorSample) -> np.ndarray:
        self._require_reset(sample)
        n = self.n_episodes
        fx = as_episodes(sample.force_x_n, n, "force_x_n")
        fy = as_episodes(sample.force_y_n, n, "force_y_n")
        ay = as_episodes(sample.accel_y_m_s2, n, "accel_y_m_s2")
        if not self._started:
            rest = self.params.law_target_n(fx, fy, 0.0)
            self.grip_force_n = np.clip(rest, 0.0, self.params.max_grip_force_n)
            self._started = True
        self.grip_force_n = fail_safe_law(self.params, fx, fy, ay, self.grip_force_n)
        self.mode = estimate_mode(
            self.grip_force_n, sample, n, self.slip_accel_threshold_m_s2, self.slip_speed_threshold_m_s
        )
        return self.grip_force_n.copy()
