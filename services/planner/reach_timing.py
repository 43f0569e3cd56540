"""Timing of the giver's reach (thesis §2.4.2).

The giver reaches the transfer point along a minimum-jerk profile (Shibata; Fig. 8)

    s(τ) = 10 τ³ − 15 τ⁴ + 6 τ⁵,  τ = t / T,

whose peak speed is 15/8 · d / T at τ = ½. The thesis normalises the velocity by the reach
distance d and finds the peak of the normalised velocity, V_max (1/s), task-independent
(0.5–2.7 1/s observed over objects and postures) except for a full cup, which is carried
significantly slower (a physical constraint: spilling). Hence

    T = (15/8) / V_max      (independent of d),      v_peak = V_max · d.

The thesis reports the range, not a central value; our defaults (1.6 1/s, the middle of the
observed range, and 1.0 1/s for spill-sensitive objects) are choices, configurable. A cap on the
peak speed (m/s) lengthens T when V_max · d would exceed it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.planner.errors import PlannerError

#: Peak of ds/dτ for the minimum-jerk profile: 30 τ² − 60 τ³ + 30 τ⁴ at τ = ½.
MIN_JERK_PEAK_FACTOR = 15.0 / 8.0
#: Range of V_max observed in the thesis's human study (§2.4.2), 1/s.
OBSERVED_NORMALISED_PEAK_VELOCITY_1_S = (0.5, 2.7)
DEFAULT_NORMALISED_PEAK_VELOCITY_1_S = 1.6
DEFAULT_SPILL_SENSITIVE_NORMALISED_PEAK_VELOCITY_1_S = 1.0


@dataclass(frozen=True)
class ReachTiming:
    """Suggested reach for the motion service.

    Attributes:
        distance_m: straight-line reach distance, m.
        duration_s: minimum-jerk duration T, s.
        peak_speed_m_s: peak hand speed, m/s.
        normalised_peak_velocity_1_s: V_max actually used (lower when the speed cap acted), 1/s.
        speed_capped: the peak-speed cap decided the duration.
    """

    distance_m: float
    duration_s: float
    peak_speed_m_s: float
    normalised_peak_velocity_1_s: float
    speed_capped: bool


def minimum_jerk_position(tau: np.ndarray) -> np.ndarray:
    """Fraction of the distance covered at normalised time τ ∈ [0, 1] (clipped)."""
    t = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return t**3 * (10.0 - 15.0 * t + 6.0 * t * t)


def minimum_jerk_speed(tau: np.ndarray) -> np.ndarray:
    """ds/dτ of the minimum-jerk profile (0 outside [0, 1])."""
    t = np.asarray(tau, dtype=float)
    v = 30.0 * t**2 * (1.0 - t) ** 2
    return np.where((t >= 0.0) & (t <= 1.0), v, 0.0)


def reach_timing(
    distance_m: float,
    normalised_peak_velocity_1_s: float = DEFAULT_NORMALISED_PEAK_VELOCITY_1_S,
    max_peak_speed_m_s: float | None = None,
) -> ReachTiming:
    """Duration and peak speed of a minimum-jerk reach over `distance_m`.

    Raises:
        PlannerError: on a negative distance, a non-positive V_max or speed cap.
    """
    if not (0.0 <= distance_m <= 10.0):
        raise PlannerError(f"reach distance {distance_m:g} m must be within 0..10 m")
    if not (0.0 < normalised_peak_velocity_1_s <= 20.0):
        raise PlannerError(
            f"normalised peak velocity {normalised_peak_velocity_1_s:g} 1/s must be within 0..20 "
            f"(the thesis observed {OBSERVED_NORMALISED_PEAK_VELOCITY_1_S[0]}–"
            f"{OBSERVED_NORMALISED_PEAK_VELOCITY_1_S[1]} 1/s)"
        )
    if max_peak_speed_m_s is not None and not (max_peak_speed_m_s > 0.0):
        raise PlannerError(f"peak speed cap {max_peak_speed_m_s:g} m/s must be positive")
    v_norm = normalised_peak_velocity_1_s
    peak = v_norm * distance_m
    capped = False
    if max_peak_speed_m_s is not None and peak > max_peak_speed_m_s:
        capped = True
        peak = float(max_peak_speed_m_s)
        v_norm = peak / distance_m
    return ReachTiming(
        distance_m=float(distance_m),
        duration_s=MIN_JERK_PEAK_FACTOR / v_norm,
        peak_speed_m_s=float(peak),
        normalised_peak_velocity_1_s=float(v_norm),
        speed_capped=bool(capped),
    )
