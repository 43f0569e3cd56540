"""The planner as the service uses it: bodies and places in, a transfer plan out.

Pure logic, no I/O. `plan_transfer` builds the dyad (anthropometrics → two planar arms placed
in the task plane), runs the DJT optimisation, maps the optimum to Baxter's `base` frame and
adds the reach timing. `receiver_from_human_state` turns the tracker's `HumanState` into the
receiver's body and place, and `ReplanPolicy` decides when a new plan is worth making.

Placement assumption (explicit, configurable): a human actor's shoulder joint is placed
`lean_fraction_of_height · H` toward the partner from where the person stands, for the trunk
lean and shoulder protraction of a real reach. With a shoulder fixed over the feet the arm
(span-scaled Drillis & Contini chain, 0.34 H shoulder → grasp) is shorter than the published
functional forward reach, and at the thesis's 100 cm separation the two workspaces overlap
so little that the optimum sits on a reach limit: the "receiver sitting → lower point"
finding then fails (see docs/planner.md). The robot giver's shoulder stays where Baxter's is.

Upper-arm cap (`ModelConfig.max_upper_arm_elevation_deg`, default 90°: upper arm at most
horizontal): the joint-torque cost is symmetric about the horizontal, so where a receiver's
reach limit binds (the live 1.75 m receiver sitting 1 m from the robot), the uncapped
optimum is the straight arm raised above the shoulder, on a cost valley so flat that tracker
noise moved it by ±7 cm and above the standing plan (docs/sitting.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bus_schema.messages import HumanState
from handover_model.body import MAX_LEAN_FRACTION
from services.planner.anthropometrics import BodyDimensions, planar_arm
from services.planner.config import PlannerConfig
from services.planner.djt import Actor, CostMap, DJTOptimum, DJTSettings, Dyad, optimise
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
        position_base_m: the same point in Baxter's `base` frame, m.
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


# --------------------------------------------------------------------------- service inputs


@dataclass(frozen=True)
class ReceiverInput:
    """What the planner needs to know about the receiver.

    Attributes:
        body: dimensions and posture.
        shoulder_x_task_m: where the receiver stands (shoulder over the feet), task x, m.
        shoulder_height_m: measured shoulder height above the floor, or None to estimate.
    """

    body: BodyDimensions
    shoulder_x_task_m: float
    shoulder_height_m: float | None


def receiver_from_human_state(
    human: HumanState, cfg: PlannerConfig, frame: TaskPlaneFrame
) -> ReceiverInput:
    """The receiver as the tracker sees it, completed with the configured defaults.

    Fields the tracker reports as 0 (height, arm span, weight, shoulder height) or
    ``unknown`` (posture) take the `receiver_default` values. The receiver's receiving
    shoulder lies in the task plane; its x is the torso's projection on the plane's x axis.

    Raises:
        PlannerError: the person is not tracked, or the reported body is implausible.
    """
    if not human.tracked:
        raise PlannerError("the receiver is not tracked")
    d = cfg.receiver_default
    posture = human.posture if human.posture != "unknown" else d.posture
    body = BodyDimensions(
        height_m=human.height_m if human.height_m > 0.0 else d.height_m,
        arm_span_m=human.arm_span_m if human.arm_span_m > 0.0 else d.arm_span_m,
        weight_kg=human.weight_kg if human.weight_kg > 0.0 else d.weight_kg,
        posture=posture,
        seat_height_m=d.seat_height_m,
    )
    shoulder_x = float(frame.base_to_task(np.asarray(human.torso_position_m))[0])
    measured = (
        human.shoulder_height_m
        if cfg.model.use_measured_shoulder_height and human.shoulder_height_m > 0.0
        else None
    )
    return ReceiverInput(body=body, shoulder_x_task_m=shoulder_x, shoulder_height_m=measured)


def geometry_for(cfg: PlannerConfig, receiver: ReceiverInput) -> DyadGeometry:
    """The dyad placement for the service's robot giver and this receiver."""
    return DyadGeometry(
        giver_shoulder_x_task_m=cfg.giver.shoulder_x_task_m,
        receiver_shoulder_x_task_m=receiver.shoulder_x_task_m,
        table_height_m=cfg.model.table_height_m,
        lean_fraction_of_height=cfg.model.lean_fraction_of_height,
        giver_is_robot=cfg.giver.is_robot,
        grasp_fraction_of_hand=cfg.model.grasp_fraction_of_hand,
        receiver_shoulder_height_m=receiver.shoulder_height_m,
    )


def timing_for(cfg: PlannerConfig) -> TimingChoice:
    t = cfg.timing
    return TimingChoice(
        t.normalised_peak_velocity_1_s,
        t.spill_sensitive_normalised_peak_velocity_1_s,
        t.max_peak_speed_m_s,
    )


def plan_for_receiver(
    cfg: PlannerConfig, receiver: ReceiverInput, object_mass_kg: float
) -> TransferPlan:
    """The service's plan: configured robot giver, this receiver, this object."""
    return plan_transfer(
        giver=cfg.giver.body(),
        receiver=receiver.body,
        object_mass_kg=object_mass_kg,
        geometry=geometry_for(cfg, receiver),
        settings=cfg.model.djt_settings(),
        frame=cfg.frame.frame(),
        timing=timing_for(cfg),
        reach_start_base_m=cfg.timing.reach_start_base_m,
        spill_sensitive=cfg.object_spill_sensitive,
    )


@dataclass(frozen=True)
class PlanInputs:
    """The inputs a plan depends on, for deciding whether to replan."""

    receiver: ReceiverInput
    object_mass_kg: float


class ReplanPolicy:
    """Replan only when the receiver moved or its body or the object changed enough."""

    def __init__(self, cfg: PlannerConfig) -> None:
        self._cfg = cfg.replan
        self._last: PlanInputs | None = None

    @property
    def last(self) -> PlanInputs | None:
        return self._last

    def reason_to_replan(self, new: PlanInputs) -> str | None:
        """Why `new` needs a new plan compared with the last accepted one (None: it does not)."""
        old = self._last
        if old is None:
            return "first plan"
        c = self._cfg
        a, b = old.receiver, new.receiver
        moved = abs(b.shoulder_x_task_m - a.shoulder_x_task_m)
        if moved > c.receiver_move_threshold_m:
            return f"receiver moved {moved:.3f} m"
        if b.body.posture != a.body.posture:
            return f"receiver posture {a.body.posture} → {b.body.posture}"
        for name in ("height_m", "arm_span_m"):
            change = abs(getattr(b.body, name) - getattr(a.body, name))
            if change > c.dimension_threshold_m:
                return f"receiver {name} changed by {change:.3f} m"
        sh_a, sh_b = a.shoulder_height_m, b.shoulder_height_m
        if (sh_a is None) != (sh_b is None) or (
            sh_a is not None and sh_b is not None and abs(sh_b - sh_a) > c.dimension_threshold_m
        ):
            return "receiver shoulder height changed"
        if abs(b.body.weight_kg - a.body.weight_kg) > c.weight_threshold_kg:
            return "receiver weight changed"
        if abs(new.object_mass_kg - old.object_mass_kg) > c.mass_threshold_kg:
            return f"object mass {old.object_mass_kg:.3f} → {new.object_mass_kg:.3f} kg"
        return None

    def accept(self, inputs: PlanInputs) -> None:
        """Remember `inputs` as the ones the current plan was made from."""
        self._last = inputs


def object_mass_from_estimate(mass_kg: float, configured_kg: float) -> float:
    """The object's mass, kg: the tracker's when it gives one (> 0), else the configured one.

    The tracker's mass comes from the task description, not the camera, so it holds while the
    object is out of view (in the gripper: ``found`` is False). Falling back to the configured
    mass whenever the object is hidden made the plan flip between two masses and re-plan."""
    if mass_kg > 0.0 and math.isfinite(mass_kg):
        return float(mass_kg)
    return float(configured_kg)



def transfer_fields(plan: TransferPlan) -> dict[str, Any]:
    """The `TransferTarget` fields (without header) that carry `plan`."""
    return {
        "position_task_m": plan.position_task_m,
        "position_base_m": plan.position_base_m,
        "cost": float(min(plan.cost, 1e12)),
        "active_constraints": list(plan.active_constraints)[:16],
        "reach_duration_s": float(plan.reach.duration_s),
        "peak_speed_m_s": float(plan.reach.peak_speed_m_s),
        "object_mass_kg": float(plan.object_mass_kg),
        "receiver_posture": plan.receiver_posture,
    }


class PlannerService:
    """The service's decisions, without the bus: latest inputs in, what to publish out.

    `step` is called whenever new data may have arrived. It plans when the policy says so,
    republishes the current plan every `republish_period_s` while the receiver is tracked and
    fresh, and never raises on bad input: an implausible body or an infeasible scene is logged
    (rate-limited by the caller's logger) and the previous plan stays.
    """

    def __init__(self, cfg: PlannerConfig, human_timeout_s: float = 1.0) -> None:
        self.cfg = cfg
        self.frame = cfg.frame.frame()
        self.policy = ReplanPolicy(cfg)
        self.human_timeout_s = human_timeout_s
        self.plan: TransferPlan | None = None
        self.plans_made = 0
        self.last_error: str | None = None
        self._last_publish_s = -math.inf

    def step(
        self,
        human: HumanState | None,
        human_rx_s: float | None,
        object_mass_kg: float,
        now_s: float,
    ) -> tuple[dict[str, Any] | None, str | None]:
        """Decide what to publish now.

        Args:
            human: latest receiver state (None before the first).
            human_rx_s: its local receive time (`time.monotonic()`), s.
            object_mass_kg: the latest object estimate's mass, kg (0 when none).
            now_s: local monotonic time, s.

        Returns:
            (fields to publish or None, a one-line note for the log or None).
        """
        if human is None or human_rx_s is None or not human.tracked:
            return None, None
        if now_s - human_rx_s > self.human_timeout_s:
            return None, None
        note = None
        mass = object_mass_from_estimate(object_mass_kg, self.cfg.object_mass_kg)
        try:
            receiver = receiver_from_human_state(human, self.cfg, self.frame)
            inputs = PlanInputs(receiver, mass)
            reason = self.policy.reason_to_replan(inputs)
            if reason is not None:
                self.plan = plan_for_receiver(self.cfg, receiver, mass)
                self.policy.accept(inputs)
                self.plans_made += 1
                self.last_error = None
                x, z = self.plan.position_task_m
                note = (
                    f"planned ({reason}): task ({x:+.3f}, {z:.3f}) m, cost {self.plan.cost:.1f}, "
                    f"active {self.plan.active_constraints or 'none'}"
                )
                self._last_publish_s = now_s
                return transfer_fields(self.plan), note
        except PlannerError as exc:
            self.last_error = str(exc)
            note = f"cannot plan: {exc}"
        if self.plan is not None and now_s - self._last_publish_s >= self.cfg.replan.republish_period_s:
            self._last_publish_s = now_s
            return transfer_fields(self.plan), note
        return None, note
