"""The DJT transfer plan: bodies and places in, the transfer point and the reach timing out.

Pure logic, no I/O. `plan_transfer` builds the dyad (anthropometrics → two planar arms placed
in the task plane, `build_dyad`), runs the DJT optimisation, maps the optimum to the scene's
`base` frame and adds the reach timing.

Placement assumption (explicit, configurable): a human actor's shoulder joint is placed
`lean_fraction_of_height · H` toward the partner from where the person stands, for the trunk
lean and shoulder protraction of a real reach. With a shoulder fixed over the feet the arm
(span-scaled Drillis & Contini chain, 0.34 H shoulder → grasp) is shorter than the published
functional forward reach, and at the thesis's 100 cm separation the two workspaces overlap
so little that the optimum sits on a reach limit: the "receiver sitting → lower point"
finding then fails (see docs/planner.md). The robot giver's shoulder stays where the robot's is.

Upper-arm cap (`ModelConfig.max_upper_arm_elevation_deg`, default 90°: upper arm at most
horizontal): the joint-torque cost is symmetric about the horizontal, so where a receiver's
reach limit binds (the live 1.75 m receiver sitting 1 m from the robot), the uncapped
optimum is the straight arm raised above the shoulder, on a cost valley so flat that tracker
noise moved it by ±7 cm and above the standing plan (docs/sitting.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handover_model.body import MAX_LEAN_FRACTION
from services.planner.anthropometrics import BodyDimensions, planar_arm
from services.planner.djt.arms import Actor, Dyad
from services.planner.djt.cost import CostMap
from services.planner.djt.optimum import DJTOptimum, optimise
from services.planner.djt.settings import DJTSettings
from services.planner.errors import PlannerError
from services.planner.frames import TaskPlaneFrame
from services.planner.reach_timing import ReachTiming, reach_timing


@dataclass(frozen=True)
class DyadGeometry:
    """Where the two actors stand and how their arms are built.

    Attributes:
        giver_shoulder_x_task_m: where the giver stands (its shoulder over the feet), task x, m.
        receiver_shoulder_x_task_m: where the receiver stands, task x, m.
        table_height_m: table top above the floor (task z = height above floor − this), m.
        lean_fraction_of_height: human shoulders are placed this fraction of their height
            toward the partner (trunk lean / protraction while reaching).
        giver_is_robot: the giver is the robot: no lean, its shoulder is where it is.
        grasp_fraction_of_hand: grasp point along the hand (0 wrist, 1 fingertip).
        giver_shoulder_height_m, receiver_shoulder_height_m: measured shoulder heights above
            the floor (m) that replace the anthropometric estimate; None to estimate.
    """

    giver_shoulder_x_task_m: float = -0.5
    receiver_shoulder_x_task_m: float = 0.5
    table_height_m: float = 0.70
    lean_fraction_of_height: float = MAX_LEAN_FRACTION
    giver_is_robot: bool = False
    grasp_fraction_of_hand: float = 0.5
    giver_shoulder_height_m: float | None = None
    receiver_shoulder_height_m: float | None = None


def build_dyad(giver: BodyDimensions, receiver: BodyDimensions, geometry: DyadGeometry) -> Dyad:
    """The two planar arms placed in the task plane (giver faces +x, receiver −x).

    Raises:
        PlannerError: on implausible bodies, or when the receiver is not in front of the giver.
    """
    g = geometry
    if g.receiver_shoulder_x_task_m - g.giver_shoulder_x_task_m < 0.2:
        raise PlannerError(
            f"the receiver (task x = {g.receiver_shoulder_x_task_m:.2f} m) must stand at least "
            f"0.2 m in front of the giver (task x = {g.giver_shoulder_x_task_m:.2f} m); "
            "check the receiver's position and the task-plane frame"
        )
    giver_arm = planar_arm(giver, g.grasp_fraction_of_hand, g.giver_shoulder_height_m)
    receiver_arm = planar_arm(receiver, g.grasp_fraction_of_hand, g.receiver_shoulder_height_m)
    giver_lean = 0.0 if g.giver_is_robot else g.lean_fraction_of_height * giver.height_m
    receiver_lean = g.lean_fraction_of_height * receiver.height_m
    return Dyad(
        giver=Actor(
            giver_arm,
            g.giver_shoulder_x_task_m + giver_lean,
            giver_arm.shoulder_height_m - g.table_height_m,
            facing=1,
        ),
        receiver=Actor(
            receiver_arm,
            g.receiver_shoulder_x_task_m - receiver_lean,
            receiver_arm.shoulder_height_m - g.table_height_m,
            facing=-1,
        ),
    )


@dataclass(frozen=True)
class TimingChoice:
    """Reach timing parameters (§2.4.2)."""

    normalised_peak_velocity_1_s: float = 1.6
    spill_sensitive_normalised_peak_velocity_1_s: float = 1.0
    max_peak_speed_m_s: float | None = 1.0


@dataclass(frozen=True)
class TransferPlan:
    """The planner's answer.

    Attributes:
        position_task_m: transfer point (x, z) in the task plane, m.
        position_base_m: the same point in the scene's `base` frame, m.
        cost: E_DJT at the point, N² m².
        active_constraints: constraints binding at the point.
        reach: suggested minimum-jerk reach from the reach start to the point.
        optimum: full DJT result (joint angles, torques).
        cost_map: the grid the optimum came from.
        dyad: the two arms that were used.
        object_mass_kg: object mass used.
        receiver_posture: receiver posture used.
    """

    position_task_m: tuple[float, float]
    position_base_m: tuple[float, float, float]
    cost: float
    active_constraints: list[str]
    reach: ReachTiming
    optimum: DJTOptimum
    cost_map: CostMap
    dyad: Dyad
    object_mass_kg: float
    receiver_posture: str


def plan_transfer(
    giver: BodyDimensions,
    receiver: BodyDimensions,
    object_mass_kg: float,
    geometry: DyadGeometry = DyadGeometry(),
    settings: DJTSettings = DJTSettings(),
    frame: TaskPlaneFrame = TaskPlaneFrame(),
    timing: TimingChoice = TimingChoice(),
    reach_start_base_m: tuple[float, float, float] | None = None,
    spill_sensitive: bool = False,
) -> TransferPlan:
    """The DJT transfer point for these actors and object, in the task plane and in `base`.

    Args:
        giver, receiver: the two bodies.
        object_mass_kg: object mass, kg.
        geometry: placement of the actors.
        settings: DJT model choices.
        frame: task plane in `base`.
        timing: reach timing choices.
        reach_start_base_m: where the giver's hand starts the reach (`base`, m); None uses
            the giver's shoulder-height point above its own shoulder position in the plane.
        spill_sensitive: a spill-sensitive object (full cup): the slower V_max.

    Raises:
        PlannerError: on bad input or when no transfer point is feasible.
    """
    dyad = build_dyad(giver, receiver, geometry)
    optimum, cmap = optimise(dyad, object_mass_kg, settings)
    p_task = np.array(optimum.position_task_m)
    p_base = frame.task_to_base(p_task)
    if reach_start_base_m is None:
        start = frame.task_to_base(np.array([dyad.giver.shoulder_x_m, 0.0]))
    else:
        start = np.asarray(reach_start_base_m, dtype=float)
    v_norm = (
        timing.spill_sensitive_normalised_peak_velocity_1_s
        if spill_sensitive
        else timing.normalised_peak_velocity_1_s
    )
    reach = reach_timing(float(np.linalg.norm(p_base - start)), v_norm, timing.max_peak_speed_m_s)
    return TransferPlan(
        position_task_m=(float(p_task[0]), float(p_task[1])),
        position_base_m=(float(p_base[0]), float(p_base[1]), float(p_base[2])),
        cost=optimum.cost,
        active_constraints=list(optimum.active_constraints),
        reach=reach,
        optimum=optimum,
        cost_map=cmap,
        dyad=dyad,
        object_mass_kg=float(object_mass_kg),
        receiver_posture=receiver.posture,
    )
