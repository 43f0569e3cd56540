"""The transfer point minimising E_DJT (thesis eq 2.4): the best point of a vectorised grid,
refined with scipy SLSQP, and the constraints that bind there."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize

from services.planner.djt.arms import Dyad, distance_limits_m, inverse_kinematics, solve_arm
from services.planner.djt.cost import CostMap, cost_map, djt_cost
from services.planner.djt.point_model import PointModel
from services.planner.djt.settings import DJTSettings, object_loads_kg
from services.planner.errors import PlannerError

log = logging.getLogger(__name__)

#: SLSQP is given a shoulder limit when the grid optimum is within this of it, rad (10°).
SHOULDER_LIMIT_WATCH_MARGIN_RAD = float(np.deg2rad(10.0))


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


def _refine(
    dyad: Dyad, start: np.ndarray, start_cost: float, object_mass_kg: float, settings: DJTSettings
) -> tuple[np.ndarray, float, bool]:
    """SLSQP from the grid point; keeps the grid point unless the result is feasible and better.

    The shoulder-range limits are SLSQP constraints too (the upper-arm cap binds for a
    receiver who sits); a result that violates any limit is rejected like any infeasible one.
    """
    model = PointModel(dyad, object_mass_kg, settings)
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
    giver_load, receiver_load = object_loads_kg(object_mass_kg, settings)
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
