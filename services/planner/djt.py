"""Dyadic joint torque model (thesis §2.2, eqs 2.1–2.4).

Each actor's arm is a planar two-link manipulator (shoulder, elbow) in the task plane (x from
giver to receiver, z up, origin at the middle of the table top, metres). For a candidate
transfer point P the arm configuration of each actor follows from analytic inverse kinematics
on the physiologically natural branch (elbow below the shoulder–hand line). The cost is

    E_DJT(P) = Σ_j τ_giver,j(P)² + Σ_j τ_receiver,j(P)²                  (2.1, 2.2)

with τ the gravity torques of the links (N m) and the object's weight W_obj mapped onto the
giver's joints only, T_obj = J_giverᵀ W_obj (eq 2.3). For a point load at the grasp point,
Jᵀ W_obj equals the gravity torque of a point mass at the hand, which is how it is computed
here. The optimum (eq 2.4) is searched over the points both can reach, at or above the table
top: first a vectorised grid, then a scipy SLSQP refinement from the best grid point.

Each actor's local frame: u along the direction it faces (the giver faces +x, the receiver −x),
w up, origin at its shoulder. Joint angles: q1 is the upper arm's angle above the facing
horizontal, q2 the elbow flexion (0 = straight); q2 ≥ 0 puts the elbow below the line from
shoulder to hand, the natural branch for a hand held in front of the body.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.optimize import minimize

from services.planner.anthropometrics import PlanarArm
from services.planner.errors import PlannerError

log = logging.getLogger(__name__)

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
#: SLSQP is given a shoulder limit when the grid optimum is within this of it, rad (10°).
SHOULDER_LIMIT_WATCH_MARGIN_RAD = float(np.deg2rad(10.0))


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


def _loads(object_mass_kg: float, settings: DJTSettings) -> tuple[float, float]:
    m = object_mass_kg
    return {
        "giver": (m, 0.0),
        "receiver": (0.0, m),
        "both": (m / 2.0, m / 2.0),
        "none": (0.0, 0.0),
    }[settings.object_load]


def _squared_torques(
    actor: Actor, x_m: np.ndarray, z_m: np.ndarray, load_kg: float, settings: DJTSettings
) -> tuple[np.ndarray, np.ndarray]:
    """τ_shoulder² + τ_elbow² and feasibility of `actor` at points (fast grid path).

    Same IK branch as `inverse_kinematics`, written without inverse trigonometry: with
    (u, w) the hand in the actor's frame, d² = u² + w², c2 = cos q2 and s2 = sin q2 ≥ 0,
    cos q1 = (u (l1 + l2 c2) + w l2 s2) / d², sin q1 = (w (l1 + l2 c2) − u l2 s2) / d²,
    cos(q1 + q2) = cos q1 c2 − sin q1 s2.
    """
    a = actor.arm
    l1, l2 = a.upper_arm_m, a.forearm_to_grasp_m
    u = actor.facing * (np.asarray(x_m, dtype=float) - actor.shoulder_x_m)
    w = np.asarray(z_m, dtype=float) - actor.shoulder_z_m
    d2 = u * u + w * w
    d_min, d_max = distance_limits_m(a, settings)
    feasible = (d2 <= d_max * d_max + 1e-12) & (d2 >= d_min * d_min - 1e-12)
    c2 = np.clip((d2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0)
    s2 = np.sqrt(1.0 - c2 * c2)
    k1 = l1 + l2 * c2
    k2 = l2 * s2
    inv_d2 = 1.0 / np.maximum(d2, 1e-12)
    cos_q1 = (u * k1 + w * k2) * inv_d2
    sin_q1 = (w * k1 - u * k2) * inv_d2
    cos_q12 = cos_q1 * c2 - sin_q1 * s2
    q1_lo, q1_hi = settings.shoulder_angle_range_rad
    q1 = np.arctan2(sin_q1, cos_q1)
    feasible &= (q1 >= q1_lo - ANGLE_TOLERANCE_RAD) & (q1 <= q1_hi + ANGLE_TOLERANCE_RAD)
    g = settings.gravity_m_s2
    distal = a.forearm_hand_mass_kg * a.forearm_hand_com_m + load_kg * l2
    proximal = a.upper_arm_mass_kg * a.upper_arm_com_m + (a.forearm_hand_mass_kg + load_kg) * l1
    tau_e = (g * distal) * cos_q12
    tau_s = (g * proximal) * cos_q1 + tau_e
    return tau_s * tau_s + tau_e * tau_e, feasible


def djt_cost(
    dyad: Dyad,
    x_m: np.ndarray,
    z_m: np.ndarray,
    object_mass_kg: float,
    settings: DJTSettings,
) -> tuple[np.ndarray, np.ndarray]:
    """E_DJT (N² m²) at task-plane points and the feasibility mask (vectorised).

    Infeasible points (out of either workspace, beyond a joint limit, or below the table
    minimum height) get cost +inf.
    """
    giver_load, receiver_load = _loads(object_mass_kg, settings)
    eg, fg = _squared_torques(dyad.giver, x_m, z_m, giver_load, settings)
    er, fr = _squared_torques(dyad.receiver, x_m, z_m, receiver_load, settings)
    feasible = fg & fr & (np.asarray(z_m) >= settings.min_height_above_table_m - 1e-12)
    return np.where(feasible, eg + er, np.inf), feasible


@dataclass(frozen=True)
class CostMap:
    """E_DJT on a regular grid of the task plane.

    Attributes:
        x_m: grid x values (nx,), m.
        z_m: grid z values (nz,), m.
        cost: (nz, nx) E_DJT, N² m², +inf where infeasible.
        feasible: (nz, nx) mask of the region both can reach above the table.
    """

    x_m: np.ndarray
    z_m: np.ndarray
    cost: np.ndarray
    feasible: np.ndarray


def search_bounds(dyad: Dyad, settings: DJTSettings) -> tuple[float, float, float, float]:
    """Bounding box (x_lo, x_hi, z_lo, z_hi) of the region both can reach above the table, m.

    Raises:
        PlannerError: when the two workspaces do not overlap above the table.
    """
    boxes = []
    for actor in (dyad.giver, dyad.receiver):
        _, d_max = distance_limits_m(actor.arm, settings)
        boxes.append(
            (
                actor.shoulder_x_m - d_max,
                actor.shoulder_x_m + d_max,
                actor.shoulder_z_m - d_max,
                actor.shoulder_z_m + d_max,
            )
        )
    x_lo = max(b[0] for b in boxes)
    x_hi = min(b[1] for b in boxes)
    z_lo = max(max(b[2] for b in boxes), settings.min_height_above_table_m)
    z_hi = min(b[3] for b in boxes)
    if x_lo > x_hi or z_lo > z_hi:
        raise PlannerError(
            "the giver's and the receiver's workspaces do not overlap above the table: "
            f"shoulders at x = {dyad.giver.shoulder_x_m:.2f} m and {dyad.receiver.shoulder_x_m:.2f} m, "
            f"reaches {dyad.giver.arm.reach_m:.2f} m and {dyad.receiver.arm.reach_m:.2f} m; "
            "check the receiver's position and the body dimensions"
        )
    return x_lo, x_hi, z_lo, z_hi


def cost_map(
    dyad: Dyad,
    object_mass_kg: float,
    settings: DJTSettings,
    bounds: tuple[float, float, float, float] | None = None,
    resolution_m: float | None = None,
) -> CostMap:
    """E_DJT over a grid (default: the overlap's bounding box at `settings.grid_resolution_m`)."""
    x_lo, x_hi, z_lo, z_hi = bounds if bounds is not None else search_bounds(dyad, settings)
    step = resolution_m if resolution_m is not None else settings.grid_resolution_m
    xs = np.arange(x_lo, x_hi + 0.5 * step, step)
    zs = np.arange(z_lo, z_hi + 0.5 * step, step)
    xx, zz = np.meshgrid(xs, zs)
    cost, feasible = djt_cost(dyad, xx, zz, object_mass_kg, settings)
    return CostMap(xs, zs, cost, feasible)


@dataclass(frozen=True)
class DJTOptimum:
    """The optimum transfer point and what decided it.

    Attributes:
        position_task_m: (x, z) in the task plane, m.
        cost: E_DJT at the optimum, N² m².
        giver_joint_rad, receiver_joint_rad: (q1, q2) of each arm at the optimum, rad.
        giver_torque_nm, receiver_torque_nm: (shoulder, elbow) gravity torques, N m.
        active_constraints: constraints within 1 mm (or 0.5°) of binding.
        refined: the SLSQP refinement improved on the grid point.
        grid_cost: E_DJT at the best grid point.
    """

    position_task_m: tuple[float, float]
    cost: float
    giver_joint_rad: tuple[float, float]
    receiver_joint_rad: tuple[float, float]
    giver_torque_nm: tuple[float, float]
    receiver_torque_nm: tuple[float, float]
    active_constraints: list[str] = field(default_factory=list)
    refined: bool = False
    grid_cost: float = float("nan")


def _constraint_slacks(
    dyad: Dyad, p: np.ndarray, settings: DJTSettings
) -> dict[str, tuple[float, float]]:
    """Named constraint slacks at point p (≥ 0 when satisfied) and their activity tolerance."""
    slacks: dict[str, tuple[float, float]] = {
        "table": (p[1] - settings.min_height_above_table_m, 1e-3)
    }
    for role, actor in (("giver", dyad.giver), ("receiver", dyad.receiver)):
        d_min, d_max = distance_limits_m(actor.arm, settings)
        d = float(np.hypot(p[0] - actor.shoulder_x_m, p[1] - actor.shoulder_z_m))
        slacks[f"{role}_reach"] = (d_max - d, 1e-3)
        slacks[f"{role}_elbow_flexion"] = (d - d_min, 1e-3)
        q1_ik, _, _ = inverse_kinematics(actor, p[0], p[1])
        q1_lo, q1_hi = settings.shoulder_angle_range_rad
        q1 = float(q1_ik) if np.isfinite(q1_ik) else q1_lo - 1.0
        slacks[f"{role}_shoulder_range"] = (min(q1 - q1_lo, q1_hi - q1), np.deg2rad(0.5))
    return slacks


def active_constraints(dyad: Dyad, p: np.ndarray, settings: DJTSettings) -> list[str]:
    """Names of the constraints binding at task-plane point p."""
    return [name for name, (s, tol) in _constraint_slacks(dyad, p, settings).items() if s <= tol]


class _PointModel:
    """Scalar (math-module) cost and constraints at one point, for the SLSQP refinement.

    Same equations as `djt_cost`, without numpy's per-call overhead on scalars.
    """

    def __init__(self, dyad: Dyad, object_mass_kg: float, settings: DJTSettings) -> None:
        giver_load, receiver_load = _loads(object_mass_kg, settings)
        self.table_z = settings.min_height_above_table_m
        self.g = settings.gravity_m_s2
        self.q1_lo, self.q1_hi = settings.shoulder_angle_range_rad
        #: Indices (giver low, giver high, receiver low, receiver high) of the shoulder
        #: limits handed to SLSQP (see `watch_shoulder_limits_near`).
        self.watched: list[int] = [0, 1, 2, 3]
        self.arms = []
        for actor, load in ((dyad.giver, giver_load), (dyad.receiver, receiver_load)):
            a = actor.arm
            d_min, d_max = distance_limits_m(a, settings)
            distal = a.forearm_hand_mass_kg * a.forearm_hand_com_m + load * a.forearm_to_grasp_m
            proximal = a.upper_arm_mass_kg * a.upper_arm_com_m + (
                a.forearm_hand_mass_kg + load
            ) * a.upper_arm_m
            self.arms.append(
                (actor.shoulder_x_m, actor.shoulder_z_m, actor.facing, a.upper_arm_m,
                 a.forearm_to_grasp_m, proximal, distal, d_min, d_max)
            )

    def cost(self, p: np.ndarray | tuple[float, float]) -> float:
        """E_DJT at p (+inf outside either annulus)."""
        x, z = float(p[0]), float(p[1])
        total = 0.0
        for sx, sz, facing, l1, l2, proximal, distal, _, _ in self.arms:
            u, w = facing * (x - sx), z - sz
            c2 = (u * u + w * w - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
            if c2 > 1.0 or c2 < -1.0:
                return math.inf
            q2 = math.acos(c2)
            q1 = math.atan2(w, u) - math.atan2(l2 * math.sin(q2), l1 + l2 * c2)
            t_e = self.g * distal * math.cos(q1 + q2)
            t_s = self.g * proximal * math.cos(q1) + t_e
            total += t_s * t_s + t_e * t_e
        return total

    def _upper_arm_angles(self, x: float, z: float) -> list[float]:
        """q1 (rad) of each arm at (x, z) on the natural branch (c2 clipped outside the annulus)."""
        out = []
        for sx, sz, facing, l1, l2, *_rest in self.arms:
            u, w = facing * (x - sx), z - sz
            c2 = min(1.0, max(-1.0, (u * u + w * w - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)))
            s2 = math.sqrt(1.0 - c2 * c2)
            q1 = math.atan2(w, u) - math.atan2(l2 * s2, l1 + l2 * c2)
            out.append((q1 + math.pi) % (2.0 * math.pi) - math.pi)
        return out

    def watch_shoulder_limits_near(self, p: np.ndarray, margin_rad: float) -> None:
        """Give SLSQP only the shoulder limits within `margin_rad` of binding at `p`.

        q1's gradient grows without bound as an arm straightens (at the reach limit), so a
        far-off shoulder limit would only disturb the line search there.
        """
        self.watched = [
            k for k, slack in enumerate(self._all_shoulder_slacks(float(p[0]), float(p[1])))
            if slack < margin_rad
        ]

    def _all_shoulder_slacks(self, x: float, z: float) -> list[float]:
        return [s for q1 in self._upper_arm_angles(x, z) for s in (q1 - self.q1_lo, self.q1_hi - q1)]

    def _shoulder_range_slacks(self, x: float, z: float) -> list[float]:
        slacks = self._all_shoulder_slacks(x, z)
        return [slacks[k] for k in self.watched]

    def constraints(self, p: np.ndarray) -> np.ndarray:
        """Slacks (≥ 0 ok): [table, giver reach, giver fold, receiver reach, receiver fold,
        then the watched shoulder limits]."""
        x, z = float(p[0]), float(p[1])
        out = [z - self.table_z]
        for sx, sz, *_rest, d_min, d_max in self.arms:
            d = math.hypot(x - sx, z - sz)
            out += [d_max - d, d - d_min]
        return np.array(out + self._shoulder_range_slacks(x, z))

    def constraints_jacobian(self, p: np.ndarray, h: float = 1e-7) -> np.ndarray:
        x, z = float(p[0]), float(p[1])
        rows = [[0.0, 1.0]]
        for sx, sz, *_rest in self.arms:
            d = max(math.hypot(x - sx, z - sz), 1e-12)
            gx, gz = (x - sx) / d, (z - sz) / d
            rows += [[-gx, -gz], [gx, gz]]
        # Shoulder-range rows by central differences (q1 is smooth inside the annulus).
        dx = np.subtract(self._shoulder_range_slacks(x + h, z), self._shoulder_range_slacks(x - h, z))
        dz = np.subtract(self._shoulder_range_slacks(x, z + h), self._shoulder_range_slacks(x, z - h))
        return np.vstack([np.array(rows), np.stack([dx, dz], axis=1).reshape(-1, 2) / (2.0 * h)])


def _refine(
    dyad: Dyad, start: np.ndarray, start_cost: float, object_mass_kg: float, settings: DJTSettings
) -> tuple[np.ndarray, float, bool]:
    """SLSQP from the grid point; keeps the grid point unless the result is feasible and better.

    The shoulder-range limits are SLSQP constraints too (the upper-arm cap binds for a
    receiver who sits); a result that violates any limit is rejected like any infeasible one.
    """
    model = _PointModel(dyad, object_mass_kg, settings)
    model.watch_shoulder_limits_near(start, SHOULDER_LIMIT_WATCH_MARGIN_RAD)
    scale = max(start_cost, 1e-9)
    # Outside an annulus the cost is continued by a large constant for finite differences.
    outside = 10.0 * start_cost / scale

    def objective(p: np.ndarray | tuple[float, float]) -> float:
        c = model.cost(p)
        return c / scale if math.isfinite(c) else outside

    def gradient(p: np.ndarray, h: float = 1e-7) -> np.ndarray:
        # Central differences on the scalar model (cheaper than scipy's generic helper).
        x, z = float(p[0]), float(p[1])
        return np.array([
            (objective((x + h, z)) - objective((x - h, z))) / (2.0 * h),
            (objective((x, z + h)) - objective((x, z - h))) / (2.0 * h),
        ])

    try:
        res = minimize(
            objective,
            start,
            method="SLSQP",
            jac=gradient,
            constraints=[
                {"type": "ineq", "fun": model.constraints, "jac": model.constraints_jacobian}
            ],
            options={"ftol": 1e-12, "maxiter": 50},
        )
    except (ValueError, ArithmeticError) as exc:  # numerical trouble: keep the grid point
        log.debug("SLSQP refinement failed: %s", exc)
        return start, start_cost, False
    p = np.asarray(res.x, dtype=float)
    cost, feasible = djt_cost(dyad, np.array(p[0]), np.array(p[1]), object_mass_kg, settings)
    c = float(cost)
    if bool(feasible) and c < start_cost:
        return p, c, True
    return start, start_cost, False


def optimise(
    dyad: Dyad,
    object_mass_kg: float,
    settings: DJTSettings,
    cmap: CostMap | None = None,
) -> tuple[DJTOptimum, CostMap]:
    """Eq 2.4: the transfer point minimising E_DJT over the region both can reach.

    Args:
        dyad: giver and receiver.
        object_mass_kg: object mass, kg (≥ 0).
        settings: model choices.
        cmap: a precomputed cost map for this dyad, mass and settings (optional).

    Returns:
        The optimum and the cost map it came from.

    Raises:
        PlannerError: on a negative mass or when no point is feasible.
    """
    if not (0.0 <= object_mass_kg <= 50.0):
        raise PlannerError(
            f"object mass = {object_mass_kg:g} kg must be within 0..50 kg (a hand-over object)"
        )
    cmap = cmap if cmap is not None else cost_map(dyad, object_mass_kg, settings)
    if not np.any(cmap.feasible):
        raise PlannerError(
            "no point is reachable by both actors above the table at this grid resolution; "
            "check the receiver's position, posture and the body dimensions"
        )
    iz, ix = np.unravel_index(np.argmin(cmap.cost), cmap.cost.shape)
    start = np.array([cmap.x_m[ix], cmap.z_m[iz]])
    grid_cost = float(cmap.cost[iz, ix])
    p, c, refined = start, grid_cost, False
    if settings.refine:
        p, c, refined = _refine(dyad, start, grid_cost, object_mass_kg, settings)
    giver_load, receiver_load = _loads(object_mass_kg, settings)
    g = solve_arm(dyad.giver, p[0], p[1], giver_load, settings)
    r = solve_arm(dyad.receiver, p[0], p[1], receiver_load, settings)
    optimum = DJTOptimum(
        position_task_m=(float(p[0]), float(p[1])),
        cost=float(c),
        giver_joint_rad=(float(g.q1_rad), float(g.q2_rad)),
        receiver_joint_rad=(float(r.q1_rad), float(r.q2_rad)),
        giver_torque_nm=(float(g.tau_shoulder_nm), float(g.tau_elbow_nm)),
        receiver_torque_nm=(float(r.tau_shoulder_nm), float(r.tau_elbow_nm)),
        active_constraints=active_constraints(dyad, p, settings),
        refined=refined,
        grid_cost=grid_cost,
    )
    return optimum, cmap
