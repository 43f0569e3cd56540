"""Shared helpers for the contact simulator tests."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robot_sim.contact.config import SensorParams, SimConfig
from robot_sim.contact.rest import _PHYSICS


class StepGrip:
    """Grip law for tests: `before_n` until `switch_s`, then `after_n` (N)."""

    def __init__(self, before_n: float, after_n: float, switch_s: float, period_s: float = 0.01):
        self.before_n, self.after_n, self.switch_s, self.period_s = before_n, after_n, switch_s, period_s
        self._n = 1

    def reset(self, n_episodes: int = 1) -> None:
        self._n = n_episodes

    def step(self, sample) -> np.ndarray:
        f = self.after_n if sample.time_s >= self.switch_s else self.before_n
        return np.full(self._n, f)


def quiet_config(**changes) -> SimConfig:
    """A config with noiseless, unbiased sensors."""
    base = SimConfig(sensors=SensorParams(ft_noise_std_n=0.0, ft_bias_std_n=0.0))
    return replace(base, **changes)


def plant_state(p) -> str:
    """Everything a step of a one-episode `ContactPlant` can change, as exact text (`repr`:
    −0.0 is not 0.0): physics, actuator, clock, sensors, noise stream, observation."""
    o, a, f = p.optical, p.actuator, p.ft
    return repr((tuple(getattr(p, n) for n in _PHYSICS), a.finger_m, a.target_m, p.step_index, p._carry_s,
                 o._acc_x, o._acc_y, o.counts_x, o.counts_y, o.velocity_x_m_s, o.velocity_y_m_s, o.accel_y_m_s2,
                 o._filtered, o.valid, o._ms_sum, o._ms_n, f.force_x_n, f.force_y_n, p.ft_fresh, p.optical_fresh,
                 p._grip_ms_sum, p._grip_ms_n, p._noise._i, p.observation()))
