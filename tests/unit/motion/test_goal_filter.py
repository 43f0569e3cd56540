"""Which goals the motion service acts on: each once, never one sent before a stop."""

from __future__ import annotations

import numpy as np

from bus_schema.messages import MotionGoal, MotionStop
from handover_model.robots import baxter
from services.motion.goal_filter import GoalFilter

S = 1_000_000_000  # 1 s in ns
T0 = 1_700_000_000 * S


def test_copies_late_goals_and_goals_sent_before_a_stop_are_ignored():
    f = GoalFilter()
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 0, T0) is None
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 1, T0 + S // 10) == "a copy of the goal in progress"
    # A copy still coming much later (motion's report was lost for seconds) is still a copy.
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 2, T0 + 5 * S) == "a copy of the goal in progress"
    assert f.reason_to_ignore("supervisor", "e1-pick-2", 3, T0 + 6 * S) is None
    # A late copy of the first goal (sent before the second) must not take the arm back.
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 4, T0 + S // 5) == "older than a goal already accepted"
    f.stop_seen("supervisor", T0 + 7 * S)
    assert f.reason_to_ignore("supervisor", "e1-transfer-3", 5, T0 + 7 * S - 1) == "sent before a stop"
    assert f.reason_to_ignore("supervisor", "e1-retract-4", 6, T0 + 8 * S) is None
    assert f.ignored == 4


def test_sources_restarts_and_unstamped_goals():
    f = GoalFilter()
    f.stop_seen("launcher", T0 + 10 * S)  # another process's clock says nothing about this one's goals
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 0, T0) is None
    assert f.reason_to_ignore("supervisor", "e1-retract-5", 9, T0 + S) is None
    # A restarted supervisor (its goal publisher's seq starts at 0 again) reuses ids: new goals.
    assert f.reason_to_ignore("supervisor", "e1-pick-1", 0, T0 + 20 * S) is None
    # Unstamped (hand-made) goals: only copies of the goal in progress are ignored.
    assert f.reason_to_ignore("test", "a", 0, 0) is None
    assert f.reason_to_ignore("test", "a", 0, 0) == "a copy of the goal in progress"
    assert f.reason_to_ignore("test", "b", 0, 0) is None


def test_a_copy_of_the_goal_in_progress_does_not_restart_the_move(motion_config, arm_ik):
    from services.motion.core import MotionController

    controller = MotionController(motion_config, arm_ik)
    home = np.array(baxter.RIGHT_ARM_HOME_RAD)
    target = home.copy()
    target[0] += 0.5
    goal = dict(goal_id="e1-retract-1", kind="retract", joint_target_rad=list(target))
    first = MotionGoal(seq=0, stamp_ns=T0, source="supervisor", **goal)
    copy = MotionGoal(seq=1, stamp_ns=T0 + S // 10, source="supervisor", **goal)
    out = controller.step(0.0, home, [first], [])
    q = home
    for k in range(1, 30):
        out = controller.step(k * 0.01, q, [copy] if k == 20 else [], [])
        q = out.command_q_rad
    mid = out.command_q_rad[0]
    fresh = MotionController(motion_config, arm_ik)
    out2 = fresh.step(0.0, home, [first], [])
    q = home
    for k in range(1, 30):
        out2 = fresh.step(k * 0.01, q, [], [])
        q = out2.command_q_rad
    assert mid == out2.command_q_rad[0]  # the copy changed nothing
    stopped = controller.step(0.30, q, [], [MotionStop(seq=0, stamp_ns=T0 + S, source="supervisor", reason="x")])
    again = controller.step(0.31, q, [copy], [])  # the copy arrives after the stop: ignored
    assert again.status.state == "stopped" and stopped.status.state == "stopped"


def test_a_goal_sent_before_a_stop_of_the_same_tick_is_not_planned(motion_config, arm_ik):
    from services.motion.core import MotionController

    controller = MotionController(motion_config, arm_ik)
    home = np.array(baxter.RIGHT_ARM_HOME_RAD)
    target = home.copy()
    target[0] += 0.5
    late = MotionGoal(seq=0, stamp_ns=T0, source="supervisor", goal_id="e1-reach-1", kind="retract",
                      joint_target_rad=list(target))
    stop = MotionStop(seq=0, stamp_ns=T0 + S // 20, source="supervisor", reason="release")
    out = controller.step(0.0, home, [late], [stop])
    assert out.status.state == "stopped" and out.status.goal_id != "e1-reach-1"
    assert controller.goals.ignored == 1
