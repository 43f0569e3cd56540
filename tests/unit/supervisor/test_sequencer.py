"""The supervisor's state machine, driven through whole episodes with hand-made messages."""

from __future__ import annotations

import math

import pytest

from bus_schema.messages import (
    GripperState,
    HumanState,
    JointState,
    MotionStatus,
    ObjectEstimate,
    TransferTarget,
    WristWrench,
)
from services.supervisor.config import SupervisorConfig, parse_config
from services.supervisor.core import Sequencer
from services.supervisor.errors import SupervisorConfigError
from services.supervisor.targets import TargetFilter
from services.supervisor.tick_io import Snapshot

H = {"seq": 0, "stamp_ns": 0, "source": "test"}
HOME = [0.0] * 7
OBJECT_M = (0.72, -0.55, -0.17)
TARGET_M = (0.45, -0.259, 0.28)


def human(tracked=True, hand=(0.9, -0.26, 0.0)):
    return HumanState(**H, tracked=tracked, hand_position_m=hand, posture="standing")


def joints(speed=0.0):
    return JointState(**H, names=[f"j{i}" for i in range(7)], position_rad=[0.0] * 7, velocity_rad_s=[speed] * 7)


class World:
    """A scripted world around one Sequencer: the test plays motion, gripper and tracker."""

    def __init__(self, **config):
        self.seq = Sequencer(SupervisorConfig(**config), HOME)
        self.now = 100.0
        self.snap = Snapshot(now_s=self.now, human=human(), human_rx_s=self.now,
                             obj=ObjectEstimate(**H, found=True, position_m=OBJECT_M, mass_kg=0.2), obj_rx_s=self.now,
                             joints=joints(), joints_rx_s=self.now)
        self.goals, self.stops, self.summaries = [], [], []

    def record(self, actions):
        if actions.goal:
            self.goals.append(actions.goal)
        if actions.stop:
            self.stops.append(actions.stop)
        if actions.summary:
            self.summaries.append(actions.summary)
        return actions

    def tick(self, dt=0.01, **fresh):
        self.now += dt
        self.snap.now_s = self.now
        for name in ("human", "obj", "joints"):
            setattr(self.snap, f"{name}_rx_s", self.now)  # streams stay fresh
        for k, v in fresh.items():
            setattr(self.snap, k, v)
            if hasattr(self.snap, f"{k}_rx_s"):
                setattr(self.snap, f"{k}_rx_s", self.now)
        return self.record(self.seq.tick(self.snap))

    def motion(self, state, progress=1.0):
        self.snap.motion = MotionStatus(**H, goal_id=self.goals[-1]["goal_id"], state=state, progress=progress)

    def run_to_transfer(self, grip_n=9.0):
        self.record(self.seq.start_episode(self.now))
        self.tick()
        assert self.seq.phase == "pick" and self.goals[-1]["kind"] == "pick"
        for expected_step in ("down", "close"):
            self.motion("reached")
            self.tick()
            assert self.seq.episode.step == expected_step
        assert self.seq.grip_request == "carry"
        self.tick(wrench=WristWrench(**H, force_n=(0.0, 1.9, 0.0)))  # weight 0.2 kg · g = 1.96 N
        self.tick(0.15)
        assert self.seq.episode.step == "lift"
        self.motion("reached")
        self.tick()
        assert self.seq.phase == "plan"
        self.tick(target=TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=TARGET_M,
                                        reach_duration_s=1.2, peak_speed_m_s=0.5, receiver_posture="standing"))
        assert self.seq.phase == "reach" and self.seq.grip_request == "transfer"
        goal = self.goals[-1]
        assert goal["kind"] == "transfer" and goal["position_base_m"] == TARGET_M and goal["duration_s"] == 1.2
        self.motion("reached")
        self.tick(gripper=GripperState(**H, mode="grasp", grip_force_n=grip_n))
        assert self.seq.phase == "transfer"


def test_pick_approaches_from_above_then_goes_down_to_the_object():
    w = World(pregrasp_height_m=0.1)
    w.record(w.seq.start_episode(w.now))
    w.tick()
    assert w.goals[0]["position_base_m"] == pytest.approx((0.72, -0.55, -0.07))
    w.motion("reached")
    w.tick()
    assert w.goals[1]["position_base_m"] == pytest.approx(OBJECT_M)
    assert w.seq.grip_request == "open"  # fingers open on the way down
    w.motion("reached")
    w.tick()
    assert w.seq.grip_request == "carry"  # closing happens only at the object


def test_a_taking_receiver_episode_releases_stops_the_arm_and_retracts_home():
    w = World(release_dwell_s=0.5)
    w.run_to_transfer(grip_n=9.0)
    w.tick(gripper=GripperState(**H, mode="slip", grip_force_n=10.5))
    assert "slipping" in w.seq.reason and w.seq.phase == "transfer"  # holds, the gripper regrasps
    actions = w.record(w.seq.on_release(w.now, "release event from gripper"))
    assert actions.stop == {"reason": "release", "protective": False}
    assert w.seq.phase == "released" and w.seq.grip_request == "open"
    # The arm is braking: still moving, no retract yet; the stop is repeated every 50 ms.
    for _ in range(10):
        w.tick(joints=joints(0.2))
    assert w.seq.phase == "released" and len(w.stops) >= 2
    w.snap.motion = MotionStatus(**H, goal_id=w.goals[-1]["goal_id"], state="stopped")
    w.tick(0.02, joints=joints(0.0))
    rest_at = w.now
    while w.seq.phase == "released":
        w.tick(0.05)
    assert w.now - rest_at == pytest.approx(0.5, abs=0.06)
    assert w.seq.phase == "retract" and w.goals[-1]["kind"] == "retract" and w.goals[-1]["joint_target_rad"] == HOME
    assert not w.seq.resting  # mid-episode: the full 100 Hz tick
    w.motion("reached")
    w.tick()
    assert w.seq.phase == "done" and w.seq.finished and w.seq.resting  # the last episode ended
    s = w.summaries[-1]
    assert s["outcome"] == "released" and s["peak_grip_force_n"] == 10.5
    assert s["force_overshoot_n"] == pytest.approx(1.5)  # 10.5 N peak − 9.0 N at the transfer start
    assert s["transfer_point_base_m"] == TARGET_M and s["faults"] == []
    assert set(s["phase_durations_s"]) >= {"locate", "pick", "plan", "reach", "transfer", "released", "retract"}


def test_receiver_never_takes_the_object_times_out_and_retracts_holding_it():
    w = World(transfer_timeout_s=2.0)
    w.run_to_transfer()
    t0 = w.now
    while w.seq.phase == "transfer":
        w.tick(0.1)
    assert w.now - t0 == pytest.approx(2.0, abs=0.11)
    assert w.seq.phase == "retract" and w.seq.grip_request == "carry"  # keeps the object
    w.motion("reached")
    w.tick()
    assert w.summaries[-1]["outcome"] == "timeout" and "did not take" in w.summaries[-1]["reason"]


def test_release_interrupt_only_acts_once_and_only_while_the_object_can_be_released():
    w = World()
    assert w.seq.on_release(w.now).stop is None  # idle: nothing to stop
    w.run_to_transfer()
    first = w.seq.on_release(w.now)
    second = w.seq.on_release(w.now + 0.01)
    assert first.stop is not None and second.stop is None


def test_gripper_state_released_is_a_release_even_if_the_event_was_lost():
    w = World()
    w.run_to_transfer()
    actions = w.tick(gripper=GripperState(**H, mode="release", grip_force_n=0.0, released=True))
    assert actions.stop == {"reason": "release", "protective": False} and w.seq.phase == "released"


def test_receiver_lost_during_the_reach_holds_then_replans_when_back():
    w = World(human_lost_s=0.5)
    w.record(w.seq.start_episode(w.now))
    w.seq.phase = "reach"
    w.seq.episode.goal_id = "g"
    w.snap.human = human(tracked=False)
    w.tick(0.6, human=human(tracked=False))
    assert w.seq.phase == "hold" and w.stops[-1]["protective"] is False
    w.tick(0.5, human=human(tracked=True))
    assert w.seq.phase == "plan"


def test_receiver_lost_for_too_long_aborts_and_retracts_with_the_object():
    w = World(human_lost_s=0.5, human_return_s=1.0)
    w.record(w.seq.start_episode(w.now))
    w.seq.phase, w.seq.episode.goal_id = "reach", "g"
    w.tick(0.6, human=human(tracked=False))
    assert w.seq.phase == "hold"
    for _ in range(12):
        w.tick(0.1, human=human(tracked=False))
    assert w.seq.phase == "retract" and w.seq.episode.outcome == "aborted" and w.seq.grip_request == "carry"


def test_a_moved_target_starts_a_new_reach_only_early_and_only_beyond_the_threshold():
    w = World(replan_threshold_m=0.05, max_replans=3)
    w.record(w.seq.start_episode(w.now))
    w.tick()
    w.seq.phase = "plan"
    t = TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=TARGET_M, reach_duration_s=1.0)
    w.tick(target=t)
    n = len(w.goals)
    w.motion("moving", progress=0.2)
    near = TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=(0.47, -0.259, 0.28), reach_duration_s=1.0)
    w.tick(target=near)  # 2 cm: noise, no new reach
    assert len(w.goals) == n
    far = TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=(0.55, -0.259, 0.28), reach_duration_s=1.0)
    w.tick(target=far)
    assert len(w.goals) == n + 1 and w.goals[-1]["position_base_m"] == (0.55, -0.259, 0.28)
    assert w.seq.episode.replans == 1
    w.motion("moving", progress=0.8)  # late in the reach: the receiver's hand closes the gap
    w.tick(target=TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=(0.35, -0.259, 0.28)))
    assert len(w.goals) == n + 1


def test_a_critical_fault_makes_a_protective_stop_that_never_lets_go():
    w = World()
    w.run_to_transfer()
    actions = w.record(w.seq.on_fault(w.now, "gripper: process gone (liveliness token lost)", critical=True))
    assert actions.stop["protective"] is True and "gripper" in actions.stop["reason"]
    assert w.seq.phase == "protective_stop" and w.seq.finished
    assert not w.seq.resting  # the stop is repeated at the full rate
    assert w.summaries[-1]["outcome"] == "protective_stop"
    assert w.summaries[-1]["faults"] == ["gripper: process gone (liveliness token lost)"]
    # A release after the protective stop does not start anything; no goal ever follows.
    n_goals = len(w.goals)
    w.seq.on_release(w.now)
    for _ in range(200):
        w.tick(0.01, joints=joints(0.0))
    assert len(w.goals) == n_goals and w.seq.phase == "protective_stop"
    assert len(w.stops) >= 3  # repeated (every 0.5 s once confirmed)


def test_a_report_only_fault_is_listed_but_the_handover_goes_on():
    w = World()
    w.run_to_transfer()
    actions = w.seq.on_fault(w.now, "recorder: silent: no heartbeat for 0.26 s", critical=False)
    assert actions.stop is None and w.seq.phase == "transfer"
    assert w.seq.episode.faults == ["recorder: silent: no heartbeat for 0.26 s"]


def test_grasp_that_feels_no_weight_fails_with_a_reason_naming_the_sensor():
    w = World(grasp_timeout_s=1.0)
    w.record(w.seq.start_episode(w.now))
    w.tick()
    for _ in range(2):
        w.motion("reached")
        w.tick()
    for _ in range(11):
        w.tick(0.1, wrench=WristWrench(**H, force_n=(0.0, 0.1, 0.0)))
    assert w.summaries[-1]["outcome"] == "failed" and "F_sy = 0.10 N" in w.summaries[-1]["reason"]


def test_locate_timeout_names_what_is_missing():
    w = World(locate_timeout_s=1.0)
    w.snap.obj = ObjectEstimate(**H, found=False)
    w.record(w.seq.start_episode(w.now))
    for _ in range(12):
        w.tick(0.1)
    assert w.summaries[-1]["outcome"] == "failed" and "the object" in w.summaries[-1]["reason"]
    assert "the receiver" not in w.summaries[-1]["reason"]


def test_episodes_follow_each_other_until_the_count():
    w = World(episodes=2, between_episodes_s=0.5, locate_timeout_s=0.2)
    w.snap.obj = ObjectEstimate(**H, found=False)
    w.record(w.seq.start_episode(w.now))
    resting = []
    for _ in range(40):
        w.tick(0.05)
        resting.append(w.seq.resting)
    assert [s["episode_id"] for s in w.summaries] == [1, 2] and w.seq.finished
    # Between the two episodes (done, one to come) the sequencer is not resting; after the last it is.
    assert resting[-1] and not all(resting) and resting == sorted(resting)


def test_target_filter_takes_the_median_over_its_window():
    f = TargetFilter(window_s=1.0)
    for i, x in enumerate((0.40, 0.45, 0.90, 0.46, 0.44)):
        f.offer(TransferTarget(**H, position_task_m=(0.0, 0.0), position_base_m=(x, -0.26, 0.3)), 10.0 + 0.1 * i)
    assert f.current(10.5).position_base_m[0] == pytest.approx(0.45)  # the 0.90 outlier is ignored
    assert f.current(12.0) is None  # all older than the window


def test_target_filter_follows_new_targets_and_the_window_sliding_past_old_ones():
    f = TargetFilter(window_s=1.0)
    target = lambda x: TransferTarget(**H, position_task_m=(0.0, 0.0), position_base_m=(x, -0.26, 0.3))  # noqa: E731
    f.offer(target(0.40), 10.0)
    f.offer(target(0.50), 10.5)
    assert f.current(10.6).position_base_m[0] == pytest.approx(0.45)
    assert f.current(10.7).position_base_m[0] == pytest.approx(0.45)  # same window, same answer
    f.offer(target(0.60), 10.8)
    assert f.current(10.9).position_base_m[0] == pytest.approx(0.50)  # a new target counts at once
    assert f.current(11.2).position_base_m[0] == pytest.approx(0.55)  # 0.40 (t=10.0) left the window
    assert f.current(11.7).position_base_m[0] == pytest.approx(0.60)


def test_config_rejects_bad_values_with_the_key_named():
    with pytest.raises(SupervisorConfigError, match="episodes"):
        parse_config({"episodes": -1})
    with pytest.raises(SupervisorConfigError, match="watch"):
        parse_config({"watch": {"recorder": "ignore"}})
    assert parse_config({}).watch == {"recorder": "report"}
    assert math.isclose(parse_config({"rate_hz": 50}).period_s, 0.02)


def test_a_goal_is_sent_again_until_motion_reports_on_it():
    w = World(goal_repeat_s=0.1)
    w.record(w.seq.start_episode(w.now))
    w.tick()
    first = w.goals[-1]
    for _ in range(35):  # 0.35 s without a word from motion (the goal was lost on the bus)
        w.tick()
    assert len(w.goals) == 4 and all(g == first for g in w.goals)  # the same goal, same id, 3 times more
    assert w.seq.episode.goal_repeats == 3
    w.motion("moving", progress=0.0)
    for _ in range(30):
        w.tick()
    assert len(w.goals) == 4  # reported on: not sent again


def test_a_goal_is_never_sent_again_after_a_stop():
    w = World(goal_repeat_s=0.1)
    w.run_to_transfer()
    w.tick(target=TransferTarget(**H, position_task_m=(0.0, 0.5), position_base_m=(0.45, -0.10, 0.28),
                                 reach_duration_s=1.2, peak_speed_m_s=0.5, receiver_posture="standing"))
    sent = len(w.goals)
    w.record(w.seq.on_release(w.now, "release event from gripper"))  # before motion reported on anything new
    for _ in range(40):
        w.tick(joints=joints(0.2))
    assert len(w.goals) == sent and w.seq.phase == "released"
