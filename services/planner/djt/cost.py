"""The DJT cost E_DJT (thesis eqs 2.1–2.3, N² m²) at task-plane points, vectorised, and over a
grid of the region both actors can reach above the table."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.planner.djt.arms import Actor, Dyad, distance_limits_m
from services.planner.djt.settings import ANGLE_TOLERANCE_RAD, DJTSettings, object_loads_kg
from services.planner.errors import PlannerError


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
    giver_load, receiver_load = object_loads_kg(object_mass_kg, settings)
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
