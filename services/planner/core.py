"""The planner as the service uses it: the tracker's receiver and the configuration in, what to
publish out.

Pure logic, no I/O. `receiver_from_human_state` turns the tracker's `HumanState` into the
receiver's body and place, `plan_for_receiver` plans for the configured robot giver and that
receiver (`services.planner.transfer_plan`), `ReplanPolicy` decides when a new plan is worth
making, and `PlannerService` decides what the node publishes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bus_schema.messages import PHASES_OUTSIDE_EPISODE, SUPERVISOR_STATE_FRESH_S, HumanState
from services.planner.anthropometrics import BodyDimensions
from services.planner.config import PlannerConfig
from services.planner.errors import PlannerError
from services.planner.frames import TaskPlaneFrame
from services.planner.transfer_plan import DyadGeometry, TimingChoice, TransferPlan, plan_transfer


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
    """The reach timing choices of the service's configuration."""
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


#: Supervisor phases outside an episode: nobody reads a plan then (the supervisor reads the
#: transfer target from `plan` to the end of `reach`, after a `pick` of a second and more).
REST_PHASES = PHASES_OUTSIDE_EPISODE
# A supervisor state older than SUPERVISOR_STATE_FRESH_S no longer lets the planner rest: a
# planner without a supervisor (alone, a study, a lost one) keeps its full rate.


def planner_rests(phase: str | None, state_age_s: float) -> bool:
    """Whether the planner may look at its inputs only now and then: the newest supervisor
    state (`phase`, None before the first) is at most `SUPERVISOR_STATE_FRESH_S` (s) old and
    outside an episode (`REST_PHASES`)."""
    return phase is not None and state_age_s <= SUPERVISOR_STATE_FRESH_S and phase in REST_PHASES


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
