"""Minimal grip-force laws for tests and examples (the real fail-safe controllers live in
`services/gripper/controllers/` and follow the same `GripController` protocol).

All laws step arrays of shape (n_episodes,), so one object serves one episode or a batch.
"""

from __future__ import annotations

import numpy as np

from robot_sim.contact.config import ContactSimError
from handover_model.grip import SensorSample

__all__ = ["ConstantGrip", "ReleaseAfter"]


class ConstantGrip:
    """Commands the same grip force forever (N), whatever the sensors say."""

    def __init__(self, grip_force_n: float = 10.0, period_s: float = 0.01):
        if not (np.isfinite(grip_force_n) and grip_force_n >= 0):
            raise ContactSimError(f"grip_force_n must be finite and >= 0, got {grip_force_n}")
        if not (np.isfinite(period_s) and period_s > 0):
            raise ContactSimError(f"period_s must be > 0, got {period_s}")
        self.grip_force_n = float(grip_force_n)
        self.period_s = float(period_s)
        self._out = np.full(1, self.grip_force_n)

    def reset(self, n_episodes: int = 1) -> None:
        self._out = np.full(int(n_episodes), self.grip_force_n)

    def step(self, sample: SensorSample) -> np.ndarray:
        return self._out.copy()


class ReleaseAfter:
    """Open-loop release: hold `hold_force_n` until `release_time_s`, then command 0 N.

    `release_time_s` may be a float or an array of shape (n,) (one time per episode)."""

    def __init__(self, hold_force_n: float = 10.0, release_time_s=1.5, period_s: float = 0.01):
        if not (np.isfinite(hold_force_n) and hold_force_n >= 0):
            raise ContactSimError(f"hold_force_n must be finite and >= 0, got {hold_force_n}")
        if not np.all(np.isfinite(np.asarray(release_time_s, dtype=float))):
            raise ContactSimError("release_time_s must be finite")
        self.hold_force_n = float(hold_force_n)
        self.release_time_s = np.asarray(release_time_s, dtype=float)
        self.period_s = float(period_s)
        self._n = 1

    def reset(self, n_episodes: int = 1) -> None:
        self._n = int(n_episodes)

    def step(self, sample: SensorSample) -> np.ndarray:
        out = np.where(sample.time_s >= self.release_time_s, 0.0, self.hold_force_n)
        return np.broadcast_to(out, (self._n,)).astype(float)
