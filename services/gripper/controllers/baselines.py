"""The release baselines of thesis §3.1: hold a constant grip (N) until a condition fires.

- `TimedRelease`: release a fixed time after the start;
- `ForceThresholdRelease` (Deyle et al.): release once the wrist force has changed by more
  than a threshold;
- `DisplacementRelease` (Bohren et al.): release when an impedance-controlled hand is
  displaced by more than a distance.
"""

from __future__ import annotations

import math

import numpy as np

from handover_model.grip import Mode, SensorSample
from services.gripper.controllers.common import (
    DEFAULT_PERIOD_S,
    BaseController,
    as_episodes,
    check_finite,
    check_max_force,
)
from services.gripper.errors import GripperError


class _LatchedReleaseBaseline(BaseController):
    """Hold a constant grip until a release condition fires, then open for good."""

    def __init__(self, hold_force_n: float, period_s: float) -> None:
        super().__init__(period_s)
        check_finite("hold_force_n", hold_force_n, positive=True)
        check_max_force(hold_force_n)
        self.hold_force_n = float(hold_force_n)

    def reset(self, n_episodes: int = 1) -> None:
        self._reset_common(n_episodes)
        self.released = np.zeros(self.n_episodes, dtype=bool)
        self.grip_force_n = np.full(self.n_episodes, self.hold_force_n)
        self._rest_force: np.ndarray | None = None

    def _release_condition(self, sample: SensorSample) -> np.ndarray:
        raise GripperError(f"{type(self).__name__} defines no release condition")

    def _rest(self, sample: SensorSample) -> np.ndarray:
        """Wrist force (x, y) of the first sample, shape (2, n): the reading while held at rest."""
        if self._rest_force is None:
            n = self.n_episodes
            self._rest_force = np.stack(
                [as_episodes(sample.force_x_n, n, "force_x_n"), as_episodes(sample.force_y_n, n, "force_y_n")]
            )
        return self._rest_force

    def _force_change_n(self, sample: SensorSample) -> np.ndarray:
        """Change of the wrist force since the first sample, shape (2, n), N."""
        n = self.n_episodes
        now = np.stack(
            [as_episodes(sample.force_x_n, n, "force_x_n"), as_episodes(sample.force_y_n, n, "force_y_n")]
        )
        return now - self._rest(sample)

    def step(self, sample: SensorSample) -> np.ndarray:
        self._require_reset(sample)
        self.released |= self._release_condition(sample)
        self.grip_force_n = np.where(self.released, 0.0, self.hold_force_n)
        self.mode = np.where(self.released, int(Mode.RELEASE), int(Mode.GRASP)).astype(np.int8)
        return self.grip_force_n.copy()


class TimedRelease(_LatchedReleaseBaseline):
    """Release a predefined time after the start of the episode (thesis §3.1, refs [9, 29]).

    Attributes:
        release_time_s: episode time `sample.time_s` at which the gripper opens, s.
    """

    def __init__(self, release_time_s: float = 2.0, hold_force_n: float = 15.0, period_s: float = DEFAULT_PERIOD_S):
        super().__init__(hold_force_n, period_s)
        check_finite("release_time_s", release_time_s, nonneg=True)
        self.release_time_s = float(release_time_s)

    def _release_condition(self, sample: SensorSample) -> np.ndarray:
        return np.full(self.n_episodes, float(sample.time_s) >= self.release_time_s)


class ForceThresholdRelease(_LatchedReleaseBaseline):
    """Release once the wrist force has changed by more than a threshold (Deyle et al., §3.1).

    The change is the Euclidean norm of (ΔF_sx, ΔF_sy) from the first sample (the object
    held at rest), so a pull in any direction, or a receiver taking the weight, counts.

    Attributes:
        threshold_n: force change that triggers the release, N.
    """

    def __init__(self, threshold_n: float = 3.0, hold_force_n: float = 15.0, period_s: float = DEFAULT_PERIOD_S):
        super().__init__(hold_force_n, period_s)
        check_finite("threshold_n", threshold_n, positive=True)
        self.threshold_n = float(threshold_n)

    def _release_condition(self, sample: SensorSample) -> np.ndarray:
        change = self._force_change_n(sample)
        return np.hypot(change[0], change[1]) >= self.threshold_n


class DisplacementRelease(_LatchedReleaseBaseline):
    """Release when an impedance-controlled hand is pushed away by more than a distance
    (Bohren et al., §3.1).

    The arm is modelled as the impedance it would be given: a virtual mass–spring–damper
    per axis, M ẍ + D ẋ + K x = ΔF, driven by the change of the wrist force since the
    first sample and integrated (semi-implicit Euler) at the control period. The gripper
    opens once |x| ≥ `displacement_threshold_m`. Its static release force is K times the
    threshold; short impulses (bumps) move the hand less than a slow pull of the same
    peak, which is what distinguishes it from `ForceThresholdRelease`.

    Attributes:
        displacement_threshold_m: hand displacement that triggers release, m.
        stiffness_n_m: virtual stiffness K, N/m.
        mass_kg: virtual mass M, kg.
        damping_ratio: ζ, D = 2 ζ √(K M).
    """

    def __init__(
        self,
        displacement_threshold_m: float = 0.01,
        stiffness_n_m: float = 300.0,
        mass_kg: float = 2.0,
        damping_ratio: float = 1.0,
        hold_force_n: float = 15.0,
        period_s: float = DEFAULT_PERIOD_S,
    ):
        super().__init__(hold_force_n, period_s)
        check_finite("displacement_threshold_m", displacement_threshold_m, positive=True)
        check_finite("stiffness_n_m", stiffness_n_m, positive=True)
        check_finite("mass_kg", mass_kg, positive=True)
        check_finite("damping_ratio", damping_ratio, nonneg=True)
        self.displacement_threshold_m = float(displacement_threshold_m)
        self.stiffness_n_m = float(stiffness_n_m)
        self.mass_kg = float(mass_kg)
        self.damping_n_s_m = 2.0 * damping_ratio * math.sqrt(stiffness_n_m * mass_kg)

    def reset(self, n_episodes: int = 1) -> None:
        super().reset(n_episodes)
        self.position_m = np.zeros((2, self.n_episodes))
        self.velocity_m_s = np.zeros((2, self.n_episodes))

    def _release_condition(self, sample: SensorSample) -> np.ndarray:
        force = self._force_change_n(sample)
        accel = (force - self.damping_n_s_m * self.velocity_m_s - self.stiffness_n_m * self.position_m) / self.mass_kg
        self.velocity_m_s = self.velocity_m_s + self.period_s * accel
        self.position_m = self.position_m + self.period_s * self.velocity_m_s
        return np.hypot(self.position_m[0], self.position_m[1]) >= self.displacement_threshold_m
