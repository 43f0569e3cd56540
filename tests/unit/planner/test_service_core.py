"""Service logic without a bus: receiver from HumanState, replan policy, what gets published."""

import numpy as np
import pytest

from bus_schema import topics as T
from bus_schema.codec import decode, encode
from bus_schema.messages import HumanState, TransferTarget
from handover_model import scene
from services.planner.config import load_config
from services.planner.core import (
    PlannerService,
    object_mass_from_estimate,
    plan_for_receiver,
    receiver_from_human_state,
)
from services.planner.errors import PlannerError

TORSO = (float(scene.RECEIVER_TORSO_BASE_XY_M[0]), float(scene.RECEIVER_TORSO_BASE_XY_M[1]), 0.3)


def human(**kw):
    base = dict(seq=0, stamp_ns=0, source="tracker", tracked=True, torso_position_m=TORSO,
                height_m=1.80, arm_span_m=1.82, weight_kg=78.0, posture="standing")
    base.update(kw)
    return HumanState(**base)


def test_receiver_place_and_defaults_from_human_state():
    cfg = load_config({})
    r = receiver_from_human_state(human(height_m=0.0, posture="unknown"), cfg, cfg.frame.frame())
    assert r.body.height_m == cfg.receiver_default.height_m
    assert r.body.posture == cfg.receiver_default.posture
    assert r.body.arm_span_m == 1.82
    # The torso projects onto task x = +0.5 in the default scene (receiver's shoulder).
    assert r.shoulder_x_task_m == pytest.approx(scene.ACTOR_SEPARATION_M / 2)
    assert r.shoulder_height_m is None
    r2 = receiver_from_human_state(human(shoulder_height_m=1.40), cfg, cfg.frame.frame())
    assert r2.shoulder_height_m == 1.40


def test_untracked_or_implausible_receiver_is_refused():
    cfg = load_config({})
    with pytest.raises(PlannerError, match="not tracked"):
        receiver_from_human_state(human(tracked=False), cfg, cfg.frame.frame())
    with pytest.raises(PlannerError, match="arm span"):
        receiver_from_human_state(human(arm_span_m=0.5), cfg, cfg.frame.frame())


def test_object_mass_source():
    assert object_mass_from_estimate(0.3, 0.065) == 0.3
    assert object_mass_from_estimate(0.0, 0.065) == 0.065  # no estimate yet
    assert object_mass_from_estimate(float("nan"), 0.065) == 0.065


def test_service_publishes_replans_only_on_real_changes_and_republishes():
    cfg = load_config({"replan": {"republish_period_s": 1.0, "receiver_move_threshold_m": 0.05}})
    svc = PlannerService(cfg)
    h = human()
    fields, note = svc.step(h, 10.0, 0.0, 10.0)
    assert fields is not None and note.startswith("planned (first plan)")
    first = TransferTarget(seq=0, stamp_ns=0, source="planner", **fields)
    # The message survives the bus codec (bounded fields accept it).
    assert decode(T.TRANSFER, encode(first)) == first
    # Base position is the task position through the configured frame.
    np.testing.assert_allclose(
        first.position_base_m, cfg.frame.frame().task_to_base(np.array(first.position_task_m))
    )
    # Same inputs, 0.1 s later: nothing.  A 3 cm step (below threshold): nothing.
    assert svc.step(h, 10.1, 0.0, 10.1) == (None, None)
    moved_a_bit = human(torso_position_m=(TORSO[0] + 0.03, TORSO[1], TORSO[2]))
    assert svc.step(moved_a_bit, 10.2, 0.0, 10.2)[0] is None
    assert svc.plans_made == 1
    # After the republish period: the same plan again.
    again, note = svc.step(moved_a_bit, 11.05, 0.0, 11.05)
    assert again == fields and note is None
    # The receiver steps back 10 cm: a new plan, farther from the robot.
    moved = human(torso_position_m=(TORSO[0] + 0.10, TORSO[1], TORSO[2]))
    new, note = svc.step(moved, 11.1, 0.0, 11.1)
    assert "receiver moved" in note and svc.plans_made == 2
    assert new["position_task_m"][0] > fields["position_task_m"][0]
    # The tracker's object mass replaces the configured one: a heavier object → replan.
    heavy, note = svc.step(moved, 11.2, 0.5, 11.2)
    assert "object mass" in note and heavy["object_mass_kg"] == 0.5
    assert heavy["position_task_m"][0] < new["position_task_m"][0]
    # The object goes out of view (in the gripper): the tracker still gives the task's mass,
    # so the plan keeps it and does not re-plan with the configured one.
    hidden, note = svc.step(moved, 11.3, 0.5, 11.3)
    assert hidden is None and note is None and svc.plans_made == 3


def test_service_survives_bad_bodies_and_stale_or_missing_humans():
    cfg = load_config({})
    svc = PlannerService(cfg, human_timeout_s=1.0)
    assert svc.step(None, None, 0.0, 0.0) == (None, None)
    assert svc.step(human(tracked=False), 0.0, 0.0, 0.0) == (None, None)
    assert svc.step(human(), 0.0, 0.0, 5.0) == (None, None)  # 5 s old
    fields, note = svc.step(human(arm_span_m=0.6), 1.0, 0.0, 1.0)
    assert fields is None and "cannot plan" in note and "arm span" in note
    good, _ = svc.step(human(), 2.0, 0.0, 2.0)
    assert good is not None
    # A bad frame later keeps the previous plan (republished, with the error noted).
    later, note = svc.step(human(height_m=2.9), 5.0, 0.0, 5.0)
    assert later == good and "cannot plan" in note


def test_plan_for_receiver_uses_the_robot_giver_of_section_2_5():
    cfg = load_config({})
    r = receiver_from_human_state(human(), cfg, cfg.frame.frame())
    plan = plan_for_receiver(cfg, r, 0.065)
    g = plan.dyad.giver
    assert g.shoulder_x_m == cfg.giver.shoulder_x_task_m  # a robot does not lean
    assert g.shoulder_z_m == pytest.approx(0.818 * 1.90 - 0.70)
    assert plan.reach.duration_s == pytest.approx(1.875 / 1.6)
