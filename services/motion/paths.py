"""Paths and trajectories: minimum-jerk Cartesian reaches and Ruckig joint moves and stops.

Units: metres, radians, seconds; Cartesian quantities in the scene's `base` frame.

Minimum-jerk reach (thesis §2.4.2 and §4.1, after Flash & Hogan): each axis follows the
quintic that minimises the integral of squared jerk between the boundary states. From rest to
rest it is the straight line p(t) = p0 + (p1 − p0) s(τ), τ = t/T, with
    s(τ) = 10τ³ − 15τ⁴ + 6τ⁵,
whose speed |p1 − p0| · 30τ²(1 − τ)² / T is bell-shaped, zero with zero acceleration at both
ends, and peaks at τ = ½ with 1.875 |p1 − p0| / T. A goal that pre-empts a moving arm starts
from the commanded velocity and acceleration instead (the quintic with those boundary values;
it is no longer a straight line, but it is still the minimum-jerk path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from services.motion.errors import TrajectoryError

#: Peak speed of a rest-to-rest minimum-jerk move, in units of distance / duration.
MIN_JERK_PEAK_FACTOR = 1.875


def min_jerk_phase(tau: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Normalised minimum-jerk phase s(τ) and its first two derivatives with respect to τ.

    τ is clipped to [0, 1] (the phase holds at the ends).
    """
    t = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    s = t**3 * (10.0 - 15.0 * t + 6.0 * t**2)
    ds = 30.0 * t**2 * (1.0 - t) ** 2
    dds = 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t)
    return s, ds, dds


class QuinticPath:
    """Per-axis minimum-jerk quintic from (p0, v0, a0) to (p1, 0, 0) over `duration_s`.

    Args:
        start_m, end_m: start and end positions (3,), m.
        duration_s: duration T > 0, s.
        start_velocity_m_s, start_acceleration_m_s2: start state (3,), default rest.
    """

    def __init__(
        self,
        start_m: np.ndarray,
        end_m: np.ndarray,
        duration_s: float,
        start_velocity_m_s: np.ndarray | None = None,
        start_acceleration_m_s2: np.ndarray | None = None,
    ) -> None:
        if not (math.isfinite(duration_s) and duration_s > 0.0):
            raise TrajectoryError(f"path duration must be finite and > 0 s, got {duration_s}")
        p0 = np.asarray(start_m, dtype=float)
        p1 = np.asarray(end_m, dtype=float)
        v0 = np.zeros(3) if start_velocity_m_s is None else np.asarray(start_velocity_m_s, float)
        a0 = np.zeros(3) if start_acceleration_m_s2 is None else np.asarray(start_acceleration_m_s2, float)
        T = float(duration_s)
        self.start_m, self.end_m, self.duration_s = p0, p1, T
        # Coefficients of p(t) = c0 + c1 t + c2 t² + c3 t³ + c4 t⁴ + c5 t⁵ with
        # p(T) = p1, p'(T) = 0, p''(T) = 0 (standard quintic boundary solution).
        d = p1 - p0
        c3 = (20.0 * d - (12.0 * v0) * T - (3.0 * a0) * T**2) / (2.0 * T**3)
        c4 = (-30.0 * d + (16.0 * v0) * T + (3.0 * a0) * T**2) / (2.0 * T**4)
        c5 = (12.0 * d - (6.0 * v0) * T - a0 * T**2) / (2.0 * T**5)
        self._coeffs = np.stack([p0, v0, a0 / 2.0, c3, c4, c5])  # (6, 3)

    def sample(self, t_s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration at times `t_s` (clipped to [0, T]).

        Returns arrays of shape (..., 3) for `t_s` of shape (...).
        """
        t = np.clip(np.asarray(t_s, dtype=float), 0.0, self.duration_s)[..., None]
        c = self._coeffs
        p = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))))
        v = c[1] + t * (2 * c[2] + t * (3 * c[3] + t * (4 * c[4] + t * 5 * c[5])))
        a = 2 * c[2] + t * (6 * c[3] + t * (12 * c[4] + t * 20 * c[5]))
        return p, v, a


class CartesianReach:
    """A minimum-jerk tool path: position quintic plus orientation slerp on the same phase.

    Args:
        start_m, end_m: tool positions (3,), `base` frame, m.
        start_rotation, end_rotation: tool rotations (3, 3).
        duration_s: duration, s.
        start_velocity_m_s, start_acceleration_m_s2: start state for pre-emption (default rest).
    """

    def __init__(
        self,
        start_m: np.ndarray,
        end_m: np.ndarray,
        start_rotation: np.ndarray,
        end_rotation: np.ndarray,
        duration_s: float,
        start_velocity_m_s: np.ndarray | None = None,
        start_acceleration_m_s2: np.ndarray | None = None,
    ) -> None:
        self.position = QuinticPath(
            start_m, end_m, duration_s, start_velocity_m_s, start_acceleration_m_s2
        )
        self.duration_s = float(duration_s)
        self.end_rotation = np.asarray(end_rotation, dtype=float)
        # Relative rotation start → end as an axis-angle, applied progressively (slerp).
        self._start_rotation = np.asarray(start_rotation, dtype=float)
        self._rotvec = Rotation.from_matrix(self._start_rotation.T @ self.end_rotation).as_rotvec()
        self._angle = float(np.linalg.norm(self._rotvec))

    def rotation_at_phase(self, s: float) -> np.ndarray:
        """Slerp between the start and end rotations at phase `s` in [0, 1] (Rodrigues' formula)."""
        if self._angle < 1e-12 or s >= 1.0:
            return self.end_rotation if s >= 1.0 else self._start_rotation
        angle = self._angle * s
        k = self._rotvec / self._angle
        kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        step = np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)
        return self._start_rotation @ step

    def pose_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position_m (3,), rotation (3, 3), velocity_m_s (3,)) at time `t_s`."""
        p, v, _ = self.position.sample(t_s)
        tau = min(max(t_s / self.duration_s, 0.0), 1.0)
        s = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        return p, self.rotation_at_phase(s), v


def rest_to_rest_duration_s(
    distance_m: float,
    duration_s: float,
    peak_speed_m_s: float,
    default_normalized_peak_speed_1_s: float,
    max_tool_speed_m_s: float,
    min_duration_s: float,
) -> float:
    """Duration of a rest-to-rest minimum-jerk reach over `distance_m`.

    Priority: an explicit `duration_s` > 0; else `peak_speed_m_s` > 0 (T = 1.875 D / v_peak);
    else the normalised peak speed V_max (T = 1.875 / V_max, thesis §2.4.2). The result is then
    lengthened so the peak speed stays ≤ `max_tool_speed_m_s`, and is at least `min_duration_s`.
    """
    if duration_s > 0.0:
        duration = duration_s
    elif peak_speed_m_s > 0.0:
        duration = MIN_JERK_PEAK_FACTOR * distance_m / peak_speed_m_s
    else:
        duration = MIN_JERK_PEAK_FACTOR / default_normalized_peak_speed_1_s
    duration = max(duration, MIN_JERK_PEAK_FACTOR * distance_m / max_tool_speed_m_s)
    return max(duration, min_duration_s)


def peak_speed_near(
    path: QuinticPath, point_m: np.ndarray, radius_m: float, samples: int = 400
) -> float:
    """Largest tool speed (m/s) of `path` at samples closer than `radius_m` to `point_m` (0 if none)."""
    t = np.linspace(0.0, path.duration_s, samples)
    p, v, _ = path.sample(t)
    inside = np.linalg.norm(p - np.asarray(point_m, dtype=float), axis=1) < radius_m
    if not inside.any():
        return 0.0
    return float(np.linalg.norm(v[inside], axis=1).max())


def zone_limited_duration_s(
    make_path,
    duration_s: float,
    point_m: np.ndarray,
    radius_m: float,
    speed_cap_m_s: float,
    max_stretch: float = 20.0,
) -> float:
    """Shortest duration ≥ `duration_s` whose path keeps ≤ `speed_cap_m_s` within `radius_m` of `point_m`.

    Args:
        make_path: callable duration_s → QuinticPath.
    Raises:
        TrajectoryError: even `max_stretch × duration_s` breaks the cap (a pre-empted motion
            already faster than the cap next to the hand).
    """

    def excess(d: float) -> float:
        return peak_speed_near(make_path(d), point_m, radius_m) - speed_cap_m_s * 0.999

    if excess(duration_s) <= 0.0:
        return duration_s
    upper = duration_s * max_stretch
    if excess(upper) > 0.0:
        raise TrajectoryError(
            f"cannot keep the tool at or below {speed_cap_m_s} m/s within {radius_m} m of the "
            f"receiver's hand: the arm is already moving faster there"
        )
    return float(brentq(excess, duration_s, upper, xtol=1e-4))


@dataclass(frozen=True)
class JointLimits:
    """Kinematic limits for Ruckig, per joint (n,), rad, rad/s, rad/s², rad/s³."""

    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_rad_s: np.ndarray
    acceleration_rad_s2: np.ndarray
    jerk_rad_s3: np.ndarray


class JointTrajectory:
    """A Ruckig trajectory sampled by time: `state_at(t)` → (q, dq, ddq) arrays (n,)."""

    def __init__(self, trajectory) -> None:
        self._trajectory = trajectory
        self.duration_s = float(trajectory.duration)

    def state_at(self, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, dq, ddq = self._trajectory.at_time(min(max(t_s, 0.0), self.duration_s))
        return np.array(q), np.array(dq), np.array(ddq)


class JointTrajectoryPlanner:
    """Jerk-limited joint moves and stops with Ruckig (one reused `InputParameter`)."""

    def __init__(self, dofs: int = 7) -> None:
        import ruckig

        self._ruckig = ruckig
        self._dofs = dofs
        self._otg = ruckig.Ruckig(dofs)
        self._input = ruckig.InputParameter(dofs)

    def _calculate(self) -> JointTrajectory:
        rk = self._ruckig
        trajectory = rk.Trajectory(self._dofs)
        try:
            result = self._otg.calculate(self._input, trajectory)
        except RuntimeError as exc:  # ruckig raises on invalid input
            raise TrajectoryError(f"Ruckig rejected the input: {exc}") from exc
        if result not in (rk.Result.Working, rk.Result.Finished):
            raise TrajectoryError(f"Ruckig could not compute the trajectory ({result.name})")
        return JointTrajectory(trajectory)

    def _set_start(self, q, dq, ddq, limits: JointLimits) -> None:
        inp = self._input
        inp.current_position = list(map(float, q))
        inp.current_velocity = list(map(float, dq))
        # Ruckig expects the start acceleration within the limits.
        inp.current_acceleration = list(
            map(float, np.clip(ddq, -limits.acceleration_rad_s2, limits.acceleration_rad_s2))
        )
        inp.max_velocity = list(map(float, limits.velocity_rad_s))
        inp.max_acceleration = list(map(float, limits.acceleration_rad_s2))
        inp.max_jerk = list(map(float, limits.jerk_rad_s3))

    def move(
        self,
        q_start_rad: np.ndarray,
        dq_start_rad_s: np.ndarray,
        ddq_start_rad_s2: np.ndarray,
        q_target_rad: np.ndarray,
        limits: JointLimits,
        minimum_duration_s: float = 0.0,
    ) -> JointTrajectory:
        """Time-optimal jerk-limited move to `q_target_rad` (at rest), at least `minimum_duration_s` long.

        Raises:
            TrajectoryError: the target is outside the position limits or Ruckig failed.
        """
        q_target = np.asarray(q_target_rad, dtype=float)
        outside = (q_target < limits.lower_rad) | (q_target > limits.upper_rad)
        if outside.any():
            raise TrajectoryError(
                f"joint target outside the joint limits at joint index(es) {np.flatnonzero(outside).tolist()}"
            )
        rk = self._ruckig
        self._set_start(q_start_rad, dq_start_rad_s, ddq_start_rad_s2, limits)
        inp = self._input
        inp.control_interface = rk.ControlInterface.Position
        inp.synchronization = rk.Synchronization.Time
        inp.target_position = list(map(float, q_target))
        inp.target_velocity = [0.0] * self._dofs
        inp.target_acceleration = [0.0] * self._dofs
        inp.minimum_duration = float(minimum_duration_s) if minimum_duration_s > 0.0 else None
        return self._calculate()

    def stop(
        self,
        q_start_rad: np.ndarray,
        dq_start_rad_s: np.ndarray,
        ddq_start_rad_s2: np.ndarray,
        limits: JointLimits,
    ) -> JointTrajectory:
        """Fastest jerk-limited trajectory to zero velocity and acceleration (every joint).

        Each joint brakes independently (no synchronisation), so each stops as fast as its
        limits allow.
        """
        rk = self._ruckig
        self._set_start(q_start_rad, dq_start_rad_s, ddq_start_rad_s2, limits)
        inp = self._input
        inp.control_interface = rk.ControlInterface.Velocity
        inp.synchronization = rk.Synchronization.No
        inp.target_velocity = [0.0] * self._dofs
        inp.target_acceleration = [0.0] * self._dofs
        inp.minimum_duration = None
        return self._calculate()
