"""The stop rules on their own: when a release or a fault stops the arm, how a stop is kept."""

from __future__ import annotations

import pytest

from bus_schema.messages import JointState, MotionStatus
from services.supervisor.config import SupervisorConfig
from services.supervisor.episode import Episode
from services.supervisor.stops import (
    STOP_KEEPALIVE_S,
    STOP_SETTLE_S,
    StopKeeper,
    arm_at_rest,
    goal_imminent,
    protective_stop_applies,
    release_applies,
)

H = {"seq": 0, "stamp_ns": 0, "source": "test"}
STOPPED = MotionStatus(**H, goal_id="g", state="stopped")
MOVING = MotionStatus(**H, goal_id="g", state="moving")


def joints(speed):
    return JointState(**H, names=["j0", "j1"], position_rad=[0.0, 0.0], velocity_rad_s=[speed, -speed])


def test_the_arm_is_at_rest_only_below_the_rest_speed_on_every_joint():
    assert arm_at_rest(joints(0.005), 0.01) and not arm_at_rest(joints(0.02), 0.01)
    assert not arm_at_rest(None, 0.01)
    assert not arm_at_rest(JointState(**H, names=[], position_rad=[], velocity_rad_s=[]), 0.01)


@pytest.mark.parametrize("phase, applies", [("reach", True), ("transfer", True), ("hold", True),
                                            ("locate", False), ("pick", False), ("plan", False),
                                            ("released", False), ("retract", False), ("done", False)])
def test_a_release_stops_the_arm_where_the_object_can_be_released(phase, applies):
    assert release_applies(phase, Episode(1, 0.0)) is applies
    assert not release_applies(phase, None)


def test_only_the_first_release_of_an_episode_is_the_interrupt():
    assert not release_applies("transfer", Episode(1, 0.0, release_s=5.0))


def test_a_critical_fault_stops_the_arm_in_every_phase_but_before_the_first_episode_and_after_a_protective_stop():
    done = Episode(1, 0.0, summary_sent=True)
    for phase in ("locate", "pick", "plan", "reach", "transfer", "released", "retract", "hold"):
        assert protective_stop_applies(phase, Episode(1, 0.0), critical=True)
    assert protective_stop_applies("done", done, critical=True)  # between episodes, one to come
    assert protective_stop_applies("failed", done, critical=True)
    assert not protective_stop_applies("idle", None, critical=True)  # the start waits for the services
    assert not protective_stop_applies("protective_stop", done, critical=True)  # once
    assert not protective_stop_applies("transfer", Episode(1, 0.0), critical=False)  # report-only


def test_a_goal_is_imminent_near_the_end_of_the_release_dwell_or_of_the_hold():
    cfg = SupervisorConfig(release_dwell_s=0.5, human_return_s=3.0)
    at_rest = Episode(1, 0.0, at_rest_since_s=10.0)
    assert not goal_imminent("released", at_rest, 0.0, 10.39, cfg)
    assert goal_imminent("released", at_rest, 0.0, 10.0 + 0.5 - STOP_SETTLE_S, cfg)
    assert not goal_imminent("released", Episode(1, 0.0), 5.0, 20.0, cfg)  # not at rest yet
    assert not goal_imminent("hold", None, 2.89, 0.0, cfg)
    assert goal_imminent("hold", None, 3.0 - STOP_SETTLE_S, 0.0, cfg)
    assert not goal_imminent("transfer", at_rest, 100.0, 100.0, cfg)


def test_a_stop_is_sent_again_until_confirmed_then_kept_alive():
    keeper = StopKeeper(repeat_s=0.05)
    assert keeper.send(10.0, "release", False) == {"reason": "release", "protective": False}
    assert keeper.again(10.04, MOVING, at_rest=False, goal_imminent=False) is None
    assert keeper.again(10.05, MOVING, at_rest=False, goal_imminent=False) == {"reason": "release",
                                                                               "protective": False}
    assert keeper.again(10.08, STOPPED, at_rest=False, goal_imminent=False) is None  # not at rest: not confirmed
    assert not keeper.confirmed
    assert keeper.again(10.09, STOPPED, at_rest=True, goal_imminent=False) is None
    assert keeper.confirmed
    assert keeper.again(10.05 + STOP_KEEPALIVE_S - 0.01, MOVING, at_rest=False, goal_imminent=False) is None
    assert keeper.again(10.05 + STOP_KEEPALIVE_S + 1e-9, MOVING, at_rest=False, goal_imminent=False) is not None


def test_a_confirmed_stop_keeps_clear_of_an_imminent_goal_and_a_goal_waits_for_the_settle_time():
    keeper = StopKeeper(repeat_s=0.05)
    keeper.send(10.0, "protective stop: gripper: process gone", True)
    assert not keeper.settled(10.0 + STOP_SETTLE_S - 0.01) and keeper.settled(10.0 + STOP_SETTLE_S + 1e-9)
    assert keeper.again(10.01, STOPPED, at_rest=True, goal_imminent=False) is None  # confirmed now
    assert keeper.again(11.0, STOPPED, at_rest=True, goal_imminent=True) is None  # the goal goes first
    stop = keeper.again(11.0, STOPPED, at_rest=True, goal_imminent=False)
    assert stop == {"reason": "protective stop: gripper: process gone", "protective": True}
    unconfirmed = StopKeeper(repeat_s=0.05)
    unconfirmed.send(10.0, "release", False)
    assert unconfirmed.again(10.05, MOVING, at_rest=False, goal_imminent=True) is not None  # still moving: sent
