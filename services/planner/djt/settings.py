"""The choices of the DJT model, made explicit: joint-angle limits, reach, whose joints carry
the object, the search grid (`DJTSettings`), and the constants they default to."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from services.planner.errors import PlannerError

#: Standard gravity, m/s².
STANDARD_GRAVITY_M_S2 = 9.80665
ObjectLoad = Literal["giver", "receiver", "both", "none"]
#: Highest upper-arm angle above the facing horizontal an actor holds for a handover, rad:
#: the upper arm at most horizontal (elevation 90° from hanging). The elbow may still lift the
#: hand above the shoulder. It applies to both modelled arms, the robot giver's included (the
#: thesis models the robot as a human, §2.5).
UPPER_ARM_MAX_ANGLE_RAD = 0.0
#: The thesis's model as written: no cap other than the arm pointing straight up, rad.
UPPER_ARM_UNCAPPED_ANGLE_RAD = float(np.pi / 2.0)
#: Joint-angle limits count as met within this, rad (SLSQP lands on a limit to ~1e-12).
ANGLE_TOLERANCE_RAD = 1e-9


@dataclass(frozen=True)
class DJTSettings:
    """Assumptions of the model that are choices, made explicit.

    Attributes:
        min_height_above_table_m: lowest allowed transfer point above the table top, m
            ("above the table"; raise it to leave room for the object under the hand).
        max_reach_fraction: largest shoulder → grasp distance as a fraction of the straight
            arm (1.0: the full workspace, as the thesis assumes).
        elbow_flexion_range_rad: allowed elbow flexion q2 (0 = straight), rad.
        shoulder_angle_range_rad: allowed upper-arm angle q1 above the facing horizontal,
            rad (−150° = 60° of extension behind the hanging arm, 0 = upper arm horizontal,
            +90° = arm straight up). The default caps the upper arm at horizontal (elevation
            ≤ 90°): the joint-torque cost is symmetric about the horizontal, so without the
            cap an arm stretched to its reach limit is "cheaper" raised above the shoulder,
            a posture ergonomic scores rate worst (RULA: upper arm > 90°; ISO 11226: upper-arm
            elevation > 60° not acceptable for static holding). See `UPPER_ARM_MAX_ANGLE_RAD`.
        object_load: whose joints carry the object's weight: ``giver`` (eq 2.3, the thesis),
            ``receiver``, ``both`` or ``none`` (for studying the assumption).
        grid_resolution_m: grid step of the search, m.
        refine: refine the best grid point with scipy SLSQP.
        gravity_m_s2: gravitational acceleration, m/s².
    """

    min_height_above_table_m: float = 0.0
    max_reach_fraction: float = 1.0
    elbow_flexion_range_rad: tuple[float, float] = (0.0, np.deg2rad(150.0))
    shoulder_angle_range_rad: tuple[float, float] = (np.deg2rad(-150.0), UPPER_ARM_MAX_ANGLE_RAD)
    object_load: ObjectLoad = "giver"
    grid_resolution_m: float = 0.01
    refine: bool = True
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2

    def __post_init__(self) -> None:
        if not (0.1 <= self.max_reach_fraction <= 1.0):
            raise PlannerError(
                f"max_reach_fraction = {self.max_reach_fraction:g} must be within 0.1..1"
            )
        lo, hi = self.elbow_flexion_range_rad
        if not (0.0 <= lo < hi <= np.pi):
            raise PlannerError(f"elbow flexion range {lo:g}..{hi:g} rad must lie in 0..π")
        lo, hi = self.shoulder_angle_range_rad
        if not (-np.pi <= lo < hi <= np.pi):
            raise PlannerError(f"shoulder angle range {lo:g}..{hi:g} rad must lie in −π..π")
        if not (0.001 <= self.grid_resolution_m <= 0.2):
            raise PlannerError(
                f"grid resolution {self.grid_resolution_m:g} m must be within 0.001..0.2 m"
            )
        if self.object_load not in ("giver", "receiver", "both", "none"):
            raise PlannerError(f"object_load {self.object_load!r} is not giver/receiver/both/none")
        if not (0.0 <= self.min_height_above_table_m <= 1.5):
            raise PlannerError(
                f"min_height_above_table_m = {self.min_height_above_table_m:g} must be 0..1.5 m"
            )


def object_loads_kg(object_mass_kg: float, settings: DJTSettings) -> tuple[float, float]:
    """The object mass (kg) the giver's and the receiver's joints carry, per `settings.object_load`."""
    m = object_mass_kg
    return {
        "giver": (m, 0.0),
        "receiver": (0.0, m),
        "both": (m / 2.0, m / 2.0),
        "none": (0.0, 0.0),
    }[settings.object_load]
