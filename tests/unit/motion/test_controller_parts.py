"""The parts `MotionController` composes, each on its own: goal checks, start states, the
commanded state and the status board."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import MotionGoal
from handover_model.robots import baxter
from services.motion.commanded import CommandedState
from services.motion.errors import GoalRejected
from services.motion.goal_targets import goal_joint_target_rad, goal_position_m, goal_rotation
from services.motion.ik import UPRIGHT_ROTATION
from services.motion.joint_state import ArmMeasurement
from services.motion.start_states import FRESH_MEASUREMENT_S, brake_start, goal_start
from services.motion.status import MAX_REASON_CHARS, StatusBoard

HOME = np.array(baxter.RIGHT_ARM_HOME_RAD)


def goal(**kw) -> MotionGoal:
    return MotionGoal(seq=0, stamp_ns=0, source="test", goal_id="g", **kw)


def test_goal_targets_are_checked(motion_config, arm_ik):
    assert goal_rotation(goal(kind="transfer")) is UPRIGHT_ROTATION
    quarter = goal_rotation(goal(kind="transfer", orientation_xyzw=(0.0, 0.0, 0.70712, 0.70711)))
    assert quarter @ np.array([1.0, 0.0, 0.0]) == pytest.approx([0.0, 1.0, 0.0], abs=1e-4)
    with pytest.raises(GoalRejected, match="unit quaternion"):
        goal_rotation(goal(kind="transfer", orientation_xyzw=(0.0, 0.0, 0.0, 0.9)))
    inside = tuple((np.array(motion_config.workspace_min_m) + motion_config.workspace_max_m) / 2)
    assert goal_position_m(goal(kind="transfer", position_base_m=inside), motion_config).tolist() == list(inside)
    with pytest.raises(GoalRejected, match="needs position_base_m"):
        goal_position_m(goal(kind="transfer"), motion_config)
    with pytest.raises(GoalRejected, match=r"outside the workspace: z="):
        goal_position_m(goal(kind="transfer", position_base_m=(inside[0], inside[1], 9.0)), motion_config)
    lo, hi = arm_ik.lower_rad, arm_ik.upper_rad
    assert goal_joint_target_rad(goal(kind="pick"), lo, hi) is None
    assert goal_joint_target_rad(goal(kind="joint", joint_target_rad=tuple(HOME)), lo, hi).tolist() == HOME.tolist()
    with pytest.raises(GoalRejected, match="needs 7 values"):
        goal_joint_target_rad(goal(kind="joint", joint_target_rad=(0.0,) * 6), lo, hi)
    with pytest.raises(GoalRejected, match=r"outside the joint limits at \['right_e1'\]"):
        goal_joint_target_rad(goal(kind="joint", joint_target_rad=(*HOME[:3], 9.0, *HOME[4:])), lo, hi)


def commanded_moving(arm_ik) -> CommandedState:
    c = CommandedState(arm_ik)
    c.record(HOME, 0.01)
    c.record(HOME + 0.001, 0.01)  # finite differences: 0.1 rad/s per joint
    return c


def test_a_goal_starts_from_the_command_while_moving_else_from_a_fresh_measurement(arm_ik):
    c = commanded_moving(arm_ik)
    q, dq, ddq = goal_start(True, 0.2, arm_ik, c, None, 5.0)
    assert q.tolist() == c.q_rad.tolist() and dq == pytest.approx(np.full(7, 0.1)) and q is not c.q_rad
    with pytest.raises(GoalRejected, match=r"^no fresh joint state from the bridge; is handover-bridge"):
        goal_start(False, 0.2, arm_ik, c, None, 5.0)
    stale = ArmMeasurement(HOME, None, at_s=4.5)
    with pytest.raises(GoalRejected, match=r"\(last one 0.50 s old\)"):
        goal_start(False, 0.2, arm_ik, c, stale, 5.0)
    beyond = ArmMeasurement(arm_ik.upper_rad + 0.1, None, at_s=4.9)
    q, dq, ddq = goal_start(False, 0.2, arm_ik, c, beyond, 5.0)
    assert q.tolist() == arm_ik.clip_to_limits(beyond.q_rad).tolist() and np.all(q < beyond.q_rad)
    assert not dq.any() and not ddq.any()


def test_a_brake_starts_from_a_fresh_measurement_only_with_a_lagging_servo(arm_ik):
    c = commanded_moving(arm_ik)
    dq = np.full(7, 0.5)
    fresh = ArmMeasurement(HOME, dq, at_s=10.0 - 0.02)
    q0, dq0, ddq0 = brake_start(0.05, arm_ik, c, fresh, 10.0)
    assert q0 == pytest.approx(HOME + 0.5 * 0.02) and dq0.tolist() == dq.tolist() and not ddq0.any()
    for servo_lag_s, measured in [
        (0.0, fresh),  # a servo that tracks its commands: brake from the command
        (0.05, ArmMeasurement(HOME, dq, at_s=10.0 - FRESH_MEASUREMENT_S - 0.01)),  # too old
        (0.05, ArmMeasurement(HOME, None, at_s=10.0)),  # no velocities
        (0.05, None),
    ]:
        q0, dq0, _ = brake_start(servo_lag_s, arm_ik, c, measured, 10.0)
        assert q0 is c.q_rad and dq0 is c.dq_rad_s


def test_the_commanded_state_leads_by_the_servo_lag_and_tracks_the_tool_speed(arm_ik):
    c = CommandedState(arm_ik)
    assert c.sent_q_rad(0.05) is None and not c.is_moving()
    c.record(HOME, 0.01)
    assert c.tool_speed_m_s == 0.0 and not c.is_moving()
    c.record(HOME + 0.001, 0.01)
    assert c.is_moving() and c.ddq_rad_s2 == pytest.approx(np.full(7, 10.0))
    assert c.sent_q_rad(0.05) == pytest.approx(HOME + 0.001 + 0.05 * 0.1)
    p0, p1 = arm_ik.tool_pose(HOME)[0], arm_ik.tool_pose(HOME + 0.001)[0]
    assert c.tool_speed_m_s == pytest.approx(np.linalg.norm(p1 - p0) / 0.01)
    c.tool_speed_m_s = 5000.0
    assert c.reported_tool_speed_m_s == 1000.0
    c.hold_at(arm_ik.upper_rad)
    assert not c.is_moving() and c.sent_q_rad(0.05).tolist() == arm_ik.upper_rad.tolist()


def test_the_status_board_reports_changes_of_state_goal_or_reason_only():
    board = StatusBoard()
    assert board.status.state == "idle" and not board.changed
    assert board.set("moving", "g", 0.2, progress=0.0)
    assert board.changed
    board.begin_tick()
    assert not board.set("moving", "g", 0.3, progress=1.7)  # progress and speed only
    assert not board.changed and board.status.progress == 1.0 and board.status.tool_speed_m_s == 0.3
    assert not board.set("moving", "g", 0.3)  # progress None: kept
    assert board.status.progress == 1.0
    assert board.set("failed", "g", 0.0, reason="x" * 600)
    assert len(board.status.reason) == MAX_REASON_CHARS
    board.begin_tick()
    board.set_tool_speed(0.7)
    assert board.status.tool_speed_m_s == 0.7 and board.status.state == "failed" and not board.changed
