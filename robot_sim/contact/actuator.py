"""Gripper actuator: force command → finger position → grip force (thesis eq 3.21).

The gripper is position-controlled; a linear spring (k = 5 N/cm) between finger and pad
turns position into force: F_G = k (x − x0) for x > x0, else 0 (eq 3.21), x0 being the
position where the pad touches the object. A force command F maps to the target
x = x0 + F / k (or x0 − open_gap for F ≤ 0). The position loop latches a new target at
`loop_rate_hz` (25 Hz by default, §3.6) and the finger follows with a first-order lag under
a speed limit, so a commanded force arrives late and at a bounded rate (k × speed limit:
`GripperParams.force_rate_n_per_s`, 50 N/s by default). Faster grippers (e.g. 500 N/s and a
250 Hz loop) are the same model with other numbers: `GripperParams.with_rates`, or
`SimConfig.with_gripper_rates` for a whole setup (which also reads the wrist sensor at the
loop's rate and sets the controllers' period, `SimConfig.control_period_s`).

Positions here are `finger_m` = x − x0 (m): > 0 compresses the spring, < 0 is a gap.
Works on Python floats (one episode) or numpy arrays (a batch) through the backend.
"""

from __future__ import annotations

import math

from robot_sim.contact.config import GripperParams

__all__ = ["GripperActuator", "DEAD_BAND_M"]

#: Position error below which the position loop stops on its target (m).
DEAD_BAND_M = 1e-6


class GripperActuator:
    """State and update of the spring gripper for n episodes (see the module docstring)."""

    def __init__(self, params: GripperParams, dt_s: float, xp, n: int, initial_force_n):
        self.params = params
        self.xp = xp
        self.k_n_per_m = params.spring_n_per_m
        start = xp.clip(initial_force_n, 0.0, params.max_force_n) / self.k_n_per_m
        self.finger_m = xp.full(n, 0.0) + start
        self.target_m = xp.full(n, 0.0) + start
        tau = params.lag_time_constant_s
        self._alpha = 1.0 if tau <= 0 else 1.0 - math.exp(-dt_s / tau)
        self._max_step_m = params.speed_limit_m_s * dt_s

    def target_for(self, force_command_n):
        """Finger target (m from contact) for a force command (N)."""
        xp = self.xp
        f = xp.clip(force_command_n, 0.0, self.params.max_force_n)
        if self.params.min_force_n > 0.0:
            f = xp.where(f > 0.0, xp.maximum(f, self.params.min_force_n), f)
        return xp.where(f > 0.0, f / self.k_n_per_m, -self.params.open_gap_m)

    def latch(self, force_command_n) -> None:
        """Position-loop tick: take the newest command as the target."""
        self.target_m = self.target_for(force_command_n)

    def move(self) -> None:
        """One plant step of finger motion toward the target (lag + speed limit); within the
        loop's dead band (1 µm) the finger settles on the target exactly."""
        m = self._max_step_m
        err = self.target_m - self.finger_m
        self.finger_m = self.xp.where(self.xp.abs(err) <= DEAD_BAND_M, self.target_m,
                                      self.finger_m + self.xp.clip(err * self._alpha, -m, m))

    def spring_force_n(self):
        """Force the spring would press with (N): what the gripper believes it applies."""
        return self.k_n_per_m * self.xp.maximum(self.finger_m, 0.0)

    def gap_m(self):
        """Distance between pad and object surface (m), 0 while pressing."""
        return self.xp.maximum(-self.finger_m, 0.0)
