"""The thesis's grip-force spring (eq 3.21).

A small metal plate on one finger sits on a linear spring of stiffness k; once the gripper
position passes the contact position x0 the plate presses on the object:

    F_G(x) = k (x − x0)   for x > x0,     F_G(x) = 0   for x ≤ x0

x is the gripper closing position (m, increasing as the fingers close), x0 the position at
which the plate touches the object (m). The thesis measured k = 5 N/cm = 500 N/m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.gripper.errors import GripperError

THESIS_SPRING_STIFFNESS_N_M = 500.0


@dataclass(frozen=True)
class GripSpring:
    """Linear spring between gripper position and grip force (eq 3.21).

    Attributes:
        stiffness_n_m: spring stiffness k, N/m (thesis: 5 N/cm = 500 N/m).
        contact_position_m: gripper closing position x0 at which the plate touches the
            object, m.
        max_position_m: largest position the gripper can be commanded to, m (the gripper's
            stroke: `handover_model.robots.GripperSpec.stroke_m`, 0.1 m for the default arm).
            Forces needing more are saturated.
    """

    stiffness_n_m: float = THESIS_SPRING_STIFFNESS_N_M
    contact_position_m: float = 0.0
    max_position_m: float = 0.1

    def __post_init__(self) -> None:
        if not (np.isfinite(self.stiffness_n_m) and self.stiffness_n_m > 0.0):
            raise GripperError(
                f"spring stiffness must be a positive finite number in N/m, got {self.stiffness_n_m!r}"
            )
        if not (np.isfinite(self.contact_position_m) and np.isfinite(self.max_position_m)):
            raise GripperError("spring contact and maximum positions must be finite (m)")
        if self.max_position_m <= self.contact_position_m:
            raise GripperError(
                "spring max_position_m must exceed contact_position_m "
                f"({self.max_position_m!r} <= {self.contact_position_m!r}): check the gripper travel"
            )

    @property
    def max_force_n(self) -> float:
        """Largest grip force the spring can produce within the gripper travel, N."""
        return self.stiffness_n_m * (self.max_position_m - self.contact_position_m)

    def force_n(self, position_m):
        """Grip force (N) produced at gripper position(s) `position_m` (m), eq 3.21."""
        x = np.asarray(position_m, dtype=float)
        force = self.stiffness_n_m * np.maximum(x - self.contact_position_m, 0.0)
        return float(force) if force.ndim == 0 else force

    def position_m(self, grip_force_n):
        """Gripper position(s) (m) that produce grip force(s) `grip_force_n` (N).

        Zero (or negative) force maps to the contact position x0: the plate just touches
        and presses with no force; opening further is the caller's choice. Forces beyond
        `max_force_n` saturate at `max_position_m`.
        """
        force = np.asarray(grip_force_n, dtype=float)
        if not np.all(np.isfinite(force)):
            raise GripperError("grip force must be finite (N); got NaN or inf")
        x = self.contact_position_m + np.maximum(force, 0.0) / self.stiffness_n_m
        x = np.minimum(x, self.max_position_m)
        return float(x) if x.ndim == 0 else x
