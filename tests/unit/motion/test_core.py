"""The motion state machine, run against an ideal arm (measured = commanded) at 100 Hz."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bus_schema.messages import MotionGoal, MotionStop
from handover_model import scene
from handover_model.robots import baxter
from services.motion.core import MotionController
from services.motion.errors import MotionError
from services.motion.ik import UPRIGHT_ROTATION, rotation_error_rad
from services.motion.joint_state import arm_positions_from
from services.motion.preview import preview

HOME = np.array(baxter.RIGHT_ARM_HOME_RAD)
TRANSFER = tuple(scene.task_to_base(np.array([0.05, 0.35])))


def goal(**kw) -> MotionGoal:
    return MotionGoal(seq=0, stamp_ns=0, source="test", **kw)


def stop(reason="release") -> MotionStop:
    return MotionStop(seq=0, stamp_ns=0, source="test", reason=reason)


@pytest.fixture
def controller(motion_config, arm_ik) -> MotionController:
    return MotionController(motion_config, arm_ik)


@pytest.fixture(scope="module")
def q_pick(motion_config, arm_ik) -> np.ndarray:
    rec = preview(MotionController(motion_config, arm_ik),
                  goal(goal_id="pick", kind="pick", position_base_m=tuple(scene.OBJECT_PICK_BASE_M)), HOME)
    assert rec.final_status.state == "reached"
    return rec.q_rad[-1]


def test_pick_reaches_the_object_upright(q_pick, pin_arm):
    p, r = pin_arm.tool_pose(q_pick)
    assert np.linalg.norm(p - scene.OBJECT_PICK_BASE_M) <= 1e-3
    assert rotation_error_rad(r, UPRIGHT_ROTATION) <= math.radians(1.0)


def test_transfer_is_a_straight_min_jerk_reach_to_the_goal(controller, q_pick, pin_arm):
    rec = preview(controller, goal(goal_id="t1", kind="transfer", position_base_m=TRANSFER), q_pick)
    assert rec.final_status.state == "reached" and rec.final_status.goal_id == "t1"
    assert rec.state[0] == "moving" and rec.state[-1] == "reached"
    p_end, r_end = pin_arm.tool_pose(rec.q_rad[-1])
    assert np.linalg.norm(p_end - TRANSFER) <= 1e-3
    assert rotation_error_rad(r_end, UPRIGHT_ROTATION) <= math.radians(1.0)
    # Commanded tool path stays within the tracking tolerance of the straight segment.
    p0 = pin_arm.tool_pose(q_pick)[0]
    d = (np.array(TRANSFER) - p0) / np.linalg.norm(np.array(TRANSFER) - p0)
    tools = np.array([pin_arm.tool_pose(q)[0] for q in rec.q_rad])
    off_line = np.linalg.norm(np.cross(tools - p0, d), axis=1)
    assert off_line.max() < 0.005
    # Default duration: 1.875 / V_max with V_max = 1.5 1/s → 1.25 s; peak speed near 1.875 D / T.
    assert rec.planned_duration_s == pytest.approx(1.25)
    distance = np.linalg.norm(np.array(TRANSFER) - p0)
    assert rec.tool_speed_m_s.max() == pytest.approx(1.875 * distance / 1.25, rel=0.05)
    # Joint velocity limits hold on the commands.
    assert np.all(np.abs(rec.dq_rad_s) <= controller.ik.velocity_limit_rad_s * 1.001)


def test_receiver_zone_caps_tool_speed(controller, q_pick):
    hand = np.array(TRANSFER) + np.array([0.1, 0.0, 0.0])
    rec = preview(controller, goal(goal_id="t2", kind="transfer", position_base_m=TRANSFER,
                                   receiver_hand_position_m=tuple(hand)), q_pick)
    assert rec.final_status.state == "reached"
    near = np.linalg.norm(rec.tool_m - hand, axis=1) < 0.3
    assert near.any()
    assert rec.tool_speed_m_s[near].max() <= 0.25 * 1.03  # finite-difference speed of the IK commands


def test_stop_mid_reach_brakes_within_stop_limits_and_ignores_the_rest(controller, q_pick, motion_config):
    rec = preview(controller, goal(goal_id="t3", kind="transfer", position_base_m=TRANSFER), q_pick,
                  stop_at_s=0.5, stop=stop())
    assert rec.final_status.state == "stopped" and "release" in rec.final_status.reason
    i_stop = int(np.searchsorted(rec.time_s, 0.5))
    assert np.abs(rec.dq_rad_s[i_stop - 1]).max() > 0.3  # it was moving
    after = rec.dq_rad_s[i_stop:]
    at_rest = np.flatnonzero(np.abs(after).max(axis=1) < 1e-9)
    assert at_rest.size and at_rest[0] * motion_config.period_s <= 0.05
    # Deceleration within the stop limit (finite differences of the 100 Hz commands, with margin
    # for sampling the jerk-limited profile).
    acc = np.diff(rec.dq_rad_s[i_stop - 1:], axis=0) / motion_config.period_s
    assert np.abs(acc).max() <= motion_config.stop_acceleration_rad_s2 * 1.001
    # Nothing moves afterwards, and the arm is nowhere near the goal.
    assert np.allclose(rec.q_rad[-1], rec.q_rad[i_stop + at_rest[0]])
    assert np.linalg.norm(rec.tool_m[-1] - np.array(TRANSFER)) > 0.05


def test_a_new_goal_after_a_stop_moves_again(controller, q_pick, pin_arm):
    t = 0.0
    dt = controller.config.period_s
    out = controller.step(t, q_pick, [goal(goal_id="a", kind="transfer", position_base_m=TRANSFER)])
    for _ in range(30):
        t += dt
        out = controller.step(t, out.planned_q_rad)
    out = controller.step(t + dt, out.planned_q_rad, stops=[stop()])
    assert out.status.state == "stopped"
    for _ in range(20):
        t += dt
        out = controller.step(t + dt, out.planned_q_rad)
    held = out.planned_q_rad
    t += 2 * dt
    out = controller.step(t, held, [goal(goal_id="b", kind="transfer", position_base_m=TRANSFER)])
    assert out.status.state == "moving" and out.status.goal_id == "b"
    for _ in range(400):
        t += dt
        out = controller.step(t, out.planned_q_rad)
        if out.status.state != "moving":
            break
    assert out.status.state == "reached"
    assert np.linalg.norm(pin_arm.tool_pose(out.planned_q_rad)[0] - TRANSFER) <= 1e-3


def test_stop_and_goal_in_the_same_tick_stop_wins(controller, q_pick):
    out = controller.step(0.0, q_pick, [goal(goal_id="c", kind="transfer", position_base_m=TRANSFER)],
                          [stop()])
    assert out.status.state == "stopped"
    # The goal never produced a command: nothing is sent, and the bridge keeps holding.
    assert out.command_q_rad is None
    for k in range(1, 20):
        out = controller.step(0.01 * k, q_pick)
        assert out.command_q_rad is None and out.status.state == "stopped"


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        (dict(kind="transfer"), "needs position_base_m"),
        (dict(kind="transfer", position_base_m=(2.0, 0.0, 0.0)), "outside the workspace: x=2.000"),
        (dict(kind="transfer", position_base_m=(1.2, -0.26, 0.7)), "unreachable"),
        (dict(kind="pick", position_base_m=(1.25, -0.26, 0.3)), "out of reach"),
        (dict(kind="joint", joint_target_rad=[0.0, 0.0, 0.0]), "needs 7 values"),
        (dict(kind="joint", joint_target_rad=[5.0] * 7), "outside the joint limits"),
        (dict(kind="joint"), "needs joint_target_rad"),
        (dict(kind="transfer", position_base_m=TRANSFER, orientation_xyzw=(0.5, 0.5, 0.0, 0.0)),
         "not a unit quaternion"),
    ],
)
def test_bad_goals_fail_with_a_reason_and_nothing_moves(controller, kwargs, reason):
    out = controller.step(0.0, HOME, [goal(goal_id="bad", **kwargs)])
    assert out.status.state == "failed" and out.status_changed
    assert reason in out.status.reason
    assert out.command_q_rad is None  # idle before: still no command, the bridge holds


def test_goal_without_joint_state_fails(controller):
    out = controller.step(0.0, None, [goal(goal_id="x", kind="transfer", position_base_m=TRANSFER)])
    assert out.status.state == "failed" and "no fresh joint state" in out.status.reason
    controller.step(1.0, HOME)
    out = controller.step(2.0, None, [goal(goal_id="y", kind="transfer", position_base_m=TRANSFER)])
    assert out.status.state == "failed" and "1.00 s old" in out.status.reason


def test_retract_joint_move_respects_jerk_limits(controller, q_pick, motion_config):
    rec = preview(controller, goal(goal_id="r", kind="retract"), q_pick)
    assert rec.final_status.state == "reached"
    assert np.allclose(rec.q_rad[-1], HOME, atol=1e-9)
    dt = motion_config.period_s
    acc = np.diff(rec.dq_rad_s, axis=0) / dt
    assert np.abs(acc).max() <= motion_config.joint_acceleration_rad_s2 * 1.001
    jerk = np.diff(acc, axis=0) / dt
    assert np.abs(jerk).max() <= motion_config.joint_jerk_rad_s3 * 1.01


def test_reached_waits_for_the_measured_arm(controller, q_pick):
    """With a lagging arm, `reached` comes only when the measured joints are within tolerance."""
    t, dt = 0.0, controller.config.period_s
    measured = q_pick.copy()
    out = controller.step(t, measured, [goal(goal_id="lag", kind="transfer", position_base_m=TRANSFER)])
    states = []
    for _ in range(500):
        t += dt
        measured = measured + (out.command_q_rad - measured) * (1 - math.exp(-dt / 0.1))
        out = controller.step(t, measured)
        states.append(out.status.state)
        if out.status.state == "reached":
            break
    assert out.status.state == "reached"
    assert np.abs(measured - out.command_q_rad).max() <= controller.config.reach_joint_tolerance_rad
    assert t > controller.planned_duration_s


def test_arm_positions_from_maps_names_and_rejects_missing():
    names = ["head_pan", *reversed(baxter.RIGHT_ARM_JOINTS)]
    positions = [9.0, *range(7)]
    q = arm_positions_from(names, positions)
    assert q.tolist() == list(reversed(range(7)))
    with pytest.raises(MotionError, match="lacks"):
        arm_positions_from(["right_s0"], [0.0])


def test_a_lagging_arm_comes_to_rest_after_a_stop(controller, q_pick, motion_config):
    """The sim bridge's servo (first-order lag τ = servo_lag_s, exact discretisation) follows
    the sent commands; after a stop mid-reach its speed falls below 0.01 rad/s.

    Measured here: ~150 ms (a coasting servo needs τ ln(v/0.01) ≈ 230 ms from 1 rad/s); the
    DESIGN target of 50 ms is NOT met with this servo model (see docs/motion.md)."""
    from robot_sim.arm import SimulatedArm

    tau, dt = motion_config.servo_lag_s, motion_config.period_s
    arm = SimulatedArm(tau, initial_position_rad=q_pick)
    t = 0.0
    out = controller.step(t, arm.state.position_rad, [goal(goal_id="lag", kind="transfer", position_base_m=TRANSFER)],
                          measured_dq_rad_s=arm.state.velocity_rad_s)
    tracking = []
    while t < 0.5:
        arm.set_target(out.command_q_rad)
        arm.step(dt)
        t += dt
        out = controller.step(t, arm.state.position_rad, measured_dq_rad_s=arm.state.velocity_rad_s)
        tracking.append(np.abs(arm.state.position_rad - out.planned_q_rad).max())
    speed_at_stop = np.abs(arm.state.velocity_rad_s).max()
    assert speed_at_stop > 0.3
    out = controller.step(t, arm.state.position_rad, stops=[stop()], measured_dq_rad_s=arm.state.velocity_rad_s)
    t_stop = t
    rest_at = None
    while t < t_stop + 1.0:
        arm.set_target(out.command_q_rad)
        arm.step(dt)
        t += dt
        if rest_at is None and np.abs(arm.state.velocity_rad_s).max() < 0.01:
            rest_at = t
        out = controller.step(t, arm.state.position_rad, measured_dq_rad_s=arm.state.velocity_rad_s)
    assert rest_at is not None and rest_at - t_stop <= 0.2
    # Once stopped the arm stays put.
    q_rest = arm.state.position_rad.copy()
    for _ in range(30):
        arm.set_target(out.command_q_rad)
        arm.step(dt)
        t += dt
        out = controller.step(t, arm.state.position_rad, measured_dq_rad_s=arm.state.velocity_rad_s)
    assert np.abs(arm.state.position_rad - q_rest).max() < 2e-3


def test_a_replan_next_to_the_hand_while_moving_fast_brakes_then_reaches(controller, q_pick, motion_config):
    """A new transfer goal arrives mid-reach with the tool already faster than the 0.25 m/s cap
    inside the receiver's zone (a sitting receiver's hand lies next to a low path): no path
    from that speed meets the cap, so the arm brakes within the stop limits (Ruckig stop) and
    then reaches the new goal from rest, slow next to the hand. It does not fail."""
    period = controller.config.period_s
    out = controller.step(0.0, np.asarray(q_pick, dtype=float),
                          [goal(goal_id="a", kind="transfer", position_base_m=TRANSFER)], [])
    t = 0.0
    while t < 0.6:  # mid-reach: fast
        t += period
        out = controller.step(t, out.planned_q_rad, [], [], out.command_dq_rad_s)
    tool_now, _ = controller.ik.tool_pose(out.planned_q_rad)
    tool_next, _ = controller.ik.tool_pose(out.planned_q_rad + out.command_dq_rad_s * 1e-4)
    assert np.linalg.norm(tool_next - tool_now) / 1e-4 > 0.3  # faster than the cap
    hand = tool_now + np.array([0.05, 0.0, -0.05])  # the tool is inside the 0.3 m zone already
    new_target = tuple(np.array(TRANSFER) + np.array([0.0, 0.0, -0.03]))
    t += period
    out = controller.step(t, out.planned_q_rad, [goal(goal_id="b", kind="transfer", position_base_m=new_target,
                                                      receiver_hand_position_m=tuple(hand))], [],
                          out.command_dq_rad_s)
    assert out.status.state == "moving" and out.status.goal_id == "b", out.status
    assert "slowing down" in out.status.reason
    tools, dqs = [controller.ik.tool_pose(out.planned_q_rad)[0]], [out.command_dq_rad_s]
    while out.status.state == "moving" and t < 20.0:
        t += period
        out = controller.step(t, out.planned_q_rad, [], [], out.command_dq_rad_s)
        tools.append(controller.ik.tool_pose(out.planned_q_rad)[0])
        dqs.append(out.command_dq_rad_s)
    assert out.status.state == "reached" and out.status.goal_id == "b", out.status
    assert np.linalg.norm(tools[-1] - np.array(new_target)) < 0.002
    # Braking within the stop limits (no velocity step), then slow next to the hand.
    acc = np.abs(np.diff(np.array(dqs), axis=0)) / period
    assert acc.max() <= motion_config.stop_acceleration_rad_s2 * 1.001
    tools = np.array(tools)
    speeds = np.linalg.norm(np.diff(tools, axis=0), axis=1) / period
    at_rest = int(np.argmax(speeds < 0.01))
    assert 0 < at_rest <= 10, speeds[:30]  # it braked to (almost) rest first, within 0.1 s
    near = np.linalg.norm(tools[1:] - hand, axis=1) < 0.3
    after = np.arange(speeds.size) > at_rest
    assert (near & after).any() and speeds[near & after].max() <= 0.25 * 1.03


def test_a_stop_cancels_a_goal_waiting_for_the_arm_to_rest(controller, q_pick):
    period = controller.config.period_s
    out = controller.step(0.0, np.asarray(q_pick, dtype=float),
                          [goal(goal_id="a", kind="transfer", position_base_m=TRANSFER)], [])
    t = 0.0
    while t < 0.6:
        t += period
        out = controller.step(t, out.planned_q_rad, [], [], out.command_dq_rad_s)
    hand = controller.ik.tool_pose(out.planned_q_rad)[0] + np.array([0.05, 0.0, -0.05])
    t += period
    out = controller.step(t, out.planned_q_rad, [goal(goal_id="b", kind="transfer", position_base_m=TRANSFER,
                                                      receiver_hand_position_m=tuple(hand))], [],
                          out.command_dq_rad_s)
    assert out.status.state == "moving"
    t += period
    out = controller.step(t, out.planned_q_rad, [], [stop()], out.command_dq_rad_s)
    for _ in range(300):
        t += period
        out = controller.step(t, out.planned_q_rad, [], [], out.command_dq_rad_s)
    assert out.status.state == "stopped"  # the waiting goal never started
    assert np.abs(out.command_dq_rad_s).max() < 1e-9


def test_a_late_tick_pauses_the_path_instead_of_failing_the_reach(controller, q_pick):
    """A tick 80 ms late (the process starved of CPU) must not make the path target jump
    further than one IK step follows ("IK fell … mm behind the path"): path time advances by
    at most two periods per tick, so the reach goes on and ends at the goal."""
    period = controller.config.period_s
    out = controller.step(0.0, np.asarray(q_pick, dtype=float),
                          [goal(goal_id="a", kind="transfer", position_base_m=TRANSFER)], [])
    t = 0.0
    for k in range(400):
        t += 0.08 if k == 40 else period  # one stall mid-reach, when the tool is fast
        out = controller.step(t, out.planned_q_rad, [], [], out.command_dq_rad_s)
        assert out.status.state != "failed", out.status.reason
        if out.status.state == "reached":
            break
    assert out.status.state == "reached"
    assert np.linalg.norm(controller.ik.tool_pose(out.planned_q_rad)[0] - np.array(TRANSFER)) < 0.002
