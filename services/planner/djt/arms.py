"""The actors' arms in the task plane: placement, inverse and forward kinematics, joint
limits and gravity torques (thesis eqs 2.1–2.3), vectorised over points.

Each actor's arm is a planar two-link manipulator (shoulder, elbow). Lengths in m, angles in
rad, torques in N m; frames and angle conventions as in `services.planner.djt`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.planner.anthropometrics import PlanarArm
from services.planner.djt.settings import ANGLE_TOLERANCE_RAD, STANDARD_GRAVITY_M_S2, DJTSettings
from services.planner.errors import PlannerError


@dataclass(frozen=True)
class Actor:
    """One actor of the dyad in the task plane.

    Attributes:
        arm: the actor's two-link arm.
        shoulder_x_m: task-plane x of the shoulder joint, m.
        shoulder_z_m: task-plane z of the shoulder joint (above the table top), m.
        facing: +1 when the actor faces +x (the giver), −1 when it faces −x (the receiver).
    """

    arm: PlanarArm
    shoulder_x_m: float
    shoulder_z_m: float
    facing: int

    def __post_init__(self) -> None:
        if self.facing not in (1, -1):
            raise PlannerError(f"facing must be +1 or -1, got {self.facing!r}")


@dataclass(frozen=True)
class ArmSolution:
    """IK and torques of one actor at a batch of points (arrays of the points' shape).

    Attributes:
        q1_rad, q2_rad: shoulder angle and elbow flexion (NaN where unreachable).
        tau_shoulder_nm, tau_elbow_nm: gravity torques (N m, NaN where unreachable).
        feasible: reachable within the reach and joint limits.
    """

    q1_rad: np.ndarray
    q2_rad: np.ndarray
    tau_shoulder_nm: np.ndarray
    tau_elbow_nm: np.ndarray
    feasible: np.ndarray


def distance_limits_m(arm: PlanarArm, settings: DJTSettings) -> tuple[float, float]:
    """Shoulder → grasp distance range allowed by the elbow range and the reach fraction, m."""
    l1, l2 = arm.upper_arm_m, arm.forearm_to_grasp_m
    q2_lo, q2_hi = settings.elbow_flexion_range_rad
    d_min = np.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * np.cos(q2_hi))
    d_max = np.sqrt(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * np.cos(q2_lo))
    return float(d_min), float(min(d_max, settings.max_reach_fraction * arm.reach_m))


def inverse_kinematics(
    actor: Actor, x_m: np.ndarray, z_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Analytic IK on the natural (elbow-down, q2 ≥ 0) branch.

    Args:
        actor: the actor.
        x_m, z_m: task-plane points (any broadcastable shapes), m.

    Returns:
        (q1_rad, q2_rad, reachable): NaN angles where the point is out of the annulus
        |l1 − l2| ≤ d ≤ l1 + l2.
    """
    l1, l2 = actor.arm.upper_arm_m, actor.arm.forearm_to_grasp_m
    u = actor.facing * (np.asarray(x_m, dtype=float) - actor.shoulder_x_m)
    w = np.asarray(z_m, dtype=float) - actor.shoulder_z_m
    d2 = u * u + w * w
    cos_q2 = (d2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
    reachable = np.abs(cos_q2) <= 1.0 + 1e-12
    with np.errstate(invalid="ignore"):
        q2 = np.arccos(np.where(reachable, np.clip(cos_q2, -1.0, 1.0), np.nan))
        q1 = np.arctan2(w, u) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    q1 = (q1 + np.pi) % (2.0 * np.pi) - np.pi
    return q1, q2, reachable


def forward_kinematics(actor: Actor, q1_rad: np.ndarray, q2_rad: np.ndarray) -> np.ndarray:
    """Grasp point (..., 2) = (x, z) in the task plane for joint angles q1, q2 (rad)."""
    l1, l2 = actor.arm.upper_arm_m, actor.arm.forearm_to_grasp_m
    q1 = np.asarray(q1_rad, dtype=float)
    q12 = q1 + np.asarray(q2_rad, dtype=float)
    u = l1 * np.cos(q1) + l2 * np.cos(q12)
    w = l1 * np.sin(q1) + l2 * np.sin(q12)
    return np.stack([actor.shoulder_x_m + actor.facing * u, actor.shoulder_z_m + w], axis=-1)


def elbow_position(actor: Actor, q1_rad: np.ndarray) -> np.ndarray:
    """Elbow (..., 2) = (x, z) in the task plane for shoulder angle q1 (rad)."""
    l1 = actor.arm.upper_arm_m
    q1 = np.asarray(q1_rad, dtype=float)
    return np.stack(
        [actor.shoulder_x_m + actor.facing * l1 * np.cos(q1), actor.shoulder_z_m + l1 * np.sin(q1)],
        axis=-1,
    )


def gravity_torques(
    arm: PlanarArm,
    q1_rad: np.ndarray,
    q2_rad: np.ndarray,
    object_mass_kg: float = 0.0,
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2,
) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques (N m) that hold the arm (and a point load at the grasp point) still.

    τ_elbow    = g (m2 c2 + m_o l2) cos(q1 + q2)
    τ_shoulder = g [(m1 c1 + (m2 + m_o) l1) cos q1 + (m2 c2 + m_o l2) cos(q1 + q2)]

    The m_o terms are J(q)ᵀ W_obj of eq 2.3 with W_obj = (0, m_o g).
    """
    a = arm
    c1 = np.cos(q1_rad)
    c12 = np.cos(np.asarray(q1_rad) + np.asarray(q2_rad))
    distal = a.forearm_hand_mass_kg * a.forearm_hand_com_m + object_mass_kg * a.forearm_to_grasp_m
    proximal = a.upper_arm_mass_kg * a.upper_arm_com_m + (
        a.forearm_hand_mass_kg + object_mass_kg
    ) * a.upper_arm_m
    tau_elbow = gravity_m_s2 * distal * c12
    tau_shoulder = gravity_m_s2 * (proximal * c1 + distal * c12)
    return tau_shoulder, tau_elbow


def object_jacobian_torques(
    arm: PlanarArm, q1_rad: float, q2_rad: float, object_mass_kg: float, gravity_m_s2: float
) -> np.ndarray:
    """Eq 2.3 written out: T_obj = J(q)ᵀ W_obj with W_obj = (0, m_o g), N m (local frame)."""
    l1, l2 = arm.upper_arm_m, arm.forearm_to_grasp_m
    q12 = q1_rad + q2_rad
    jac = np.array(
        [
            [-l1 * np.sin(q1_rad) - l2 * np.sin(q12), -l2 * np.sin(q12)],
            [l1 * np.cos(q1_rad) + l2 * np.cos(q12), l2 * np.cos(q12)],
        ]
    )
    return jac.T @ np.array([0.0, object_mass_kg * gravity_m_s2])


def solve_arm(
    actor: Actor,
    x_m: np.ndarray,
    z_m: np.ndarray,
    object_mass_kg: float,
    settings: DJTSettings,
) -> ArmSolution:
    """IK, limits and gravity torques of `actor` at task-plane points (vectorised)."""
    q1, q2, reachable = inverse_kinematics(actor, x_m, z_m)
    q2_lo, q2_hi = settings.elbow_flexion_range_rad
    q1_lo, q1_hi = settings.shoulder_angle_range_rad
    d_min, d_max = distance_limits_m(actor.arm, settings)
    u = np.asarray(x_m, dtype=float) - actor.shoulder_x_m
    w = np.asarray(z_m, dtype=float) - actor.shoulder_z_m
    d = np.hypot(u, w)
    with np.errstate(invalid="ignore"):
        feasible = (
            reachable
            & (d <= d_max + 1e-12)
            & (d >= d_min - 1e-12)
            & (q2 >= q2_lo - 1e-12)
            & (q2 <= q2_hi + 1e-12)
            & (q1 >= q1_lo - ANGLE_TOLERANCE_RAD)
            & (q1 <= q1_hi + ANGLE_TOLERANCE_RAD)
        )
    tau_s, tau_e = gravity_torques(actor.arm, q1, q2, object_mass_kg, settings.gravity_m_s2)
    return ArmSolution(q1, q2, tau_s, tau_e, feasible)


@dataclass(frozen=True)
class Dyad:
    """Giver and receiver of one handover."""

    giver: Actor
    receiver: Actor

    def swapped(self) -> Dyad:
        """The same two bodies with the roles exchanged (each keeps its place and facing)."""
        return Dyad(
            giver=Actor(self.receiver.arm, -self.receiver.shoulder_x_m, self.receiver.shoulder_z_m, 1),
            receiver=Actor(self.giver.arm, -self.giver.shoulder_x_m, self.giver.shoulder_z_m, -1),
        )
