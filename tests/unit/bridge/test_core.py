"""Bridge command gate (validation, time-out) and the simulated servo."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.arm import SimulatedArm
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS, arm_model
from services.bridge.core import CommandGate, CommandRejected

J = list(RIGHT_ARM_JOINTS)
HOME = np.array(RIGHT_ARM_HOME_RAD)


@pytest.fixture
def gate():
    return CommandGate(J, arm_model().limits, command_timeout_s=0.2)


def test_valid_command_is_followed_until_timeout(gate):
    target = HOME + 0.1
    assert gate.offer(J, list(target), now_s=10.0, current_rad=HOME) is None
    d = gate.decide(10.19)
    assert not d.holding and np.allclose(d.target_rad, target)
    d = gate.decide(10.21)
    assert d.holding and "time-out 200 ms" in d.reason
    assert gate.decide(10.22).holding  # stays holding until a new command


def test_no_command_yet_holds(gate):
    d = gate.decide(0.0)
    assert d.holding and d.target_rad is None and "no joint command" in d.reason


@pytest.mark.parametrize("names,values,match", [
    (["left_s0"], [0.0], "unknown joint 'left_s0'"),
    (["right_s0", "right_s0"], [0.0, 0.1], "twice"),
    (["right_s0"], [0.0, 0.1], "1 names but 2 positions"),
    ([], [], "names no joint"),
    (["right_e1"], [3.0], "outside its limits"),
    (["right_s0"], [float("nan")], "outside its limits"),
])
def test_bad_commands_rejected_and_arm_holds(gate, names, values, match):
    assert gate.offer(J, list(HOME + 0.05), 1.0, HOME) is None
    reason = gate.offer(names, values, 1.01, HOME)
    assert reason is not None and match.split("'")[0] in reason
    with pytest.raises(CommandRejected):
        gate.validate(names, values)
    d = gate.decide(1.02)
    assert d.holding and d.target_rad is None and "rejected command" in d.reason
    assert gate.rejected == 1


def test_partial_command_keeps_other_targets(gate):
    gate.offer(J, list(HOME), 0.0, HOME)
    gate.offer(["right_w2"], [1.0], 0.05, HOME)
    d = gate.decide(0.06)
    expected = HOME.copy()
    expected[6] = 1.0
    assert np.allclose(d.target_rad, expected)


def test_limit_tolerance_accepts_rounding_and_clips(gate):
    upper = arm_model().limits.upper_rad[3]
    assert gate.offer(["right_e1"], [upper + 5e-4], 0.0, HOME) is None
    assert gate.decide(0.01).target_rad[3] == pytest.approx(upper)


def test_servo_is_first_order_lag():
    arm = SimulatedArm(time_constant_s=0.05, initial_position_rad=HOME)
    arm.set_target(HOME + np.array([0.02, 0, 0, 0, 0, 0, 0]))
    arm.step(0.05)  # one time constant: 63.2 % of a small step (no velocity saturation)
    assert arm.state.position_rad[0] - HOME[0] == pytest.approx(0.02 * (1 - np.exp(-1)), rel=1e-9)


def test_servo_respects_velocity_limit():
    limits = arm_model().limits
    arm = SimulatedArm(time_constant_s=0.05, initial_position_rad=HOME)
    arm.set_target(HOME + 1.0)
    for _ in range(10):
        arm.step(0.01)
        assert np.all(np.abs(arm.state.velocity_rad_s) <= limits.velocity_rad_s + 1e-12)
    assert np.abs(arm.state.velocity_rad_s[0]) == pytest.approx(1.5)  # saturated at 1.5 rad/s


def test_servo_stays_within_position_limits():
    limits = arm_model().limits
    arm = SimulatedArm(time_constant_s=0.02, initial_position_rad=HOME)
    arm.set_target(limits.upper_rad + 1.0)
    for _ in range(500):
        arm.step(0.01)
    assert np.all(arm.state.position_rad <= limits.upper_rad)
    assert np.allclose(arm.state.position_rad, limits.upper_rad)


def test_hold_stops_a_moving_arm_within_a_tick():
    arm = SimulatedArm(time_constant_s=0.05, initial_position_rad=HOME)
    arm.set_target(HOME + 0.5)
    for _ in range(20):
        arm.step(0.01)
    assert np.max(np.abs(arm.state.velocity_rad_s)) > 0.5
    arm.hold()
    arm.step(0.01)
    assert np.max(np.abs(arm.state.velocity_rad_s)) == 0.0


def test_fk_matches_an_independent_chain_length_bound():
    model = arm_model()
    shoulder = model.frame_positions(HOME, ["right_upper_shoulder"])[0]
    for q in (HOME, np.zeros(7), model.limits.lower_rad * 0.5):
        tool, rot = model.tool_pose(q)
        assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-9)
        # Baxter's arm is about 1.2 m from shoulder to gripper tip at full stretch.
        assert 0.1 < np.linalg.norm(tool - shoulder) < 1.35


def _track_ramp(feedforward: bool, speed=0.5, dt=0.01, steps=60):
    arm = SimulatedArm(time_constant_s=0.05, initial_position_rad=HOME)
    v = np.zeros(7)
    v[0] = speed
    for k in range(1, steps + 1):
        arm.set_target(HOME + v * k * dt, v if feedforward else None)
        arm.step(dt)
    return (HOME[0] + speed * steps * dt) - arm.state.position_rad[0]


def test_feedforward_removes_the_servo_lag():
    lag_without = _track_ramp(False)
    lag_with = _track_ramp(True)
    assert lag_without == pytest.approx(0.5 * 0.05, rel=0.15)  # trails by v·τ
    assert abs(lag_with) < 0.5 * 0.01  # within v·Δt with the commanded rate


def test_rest_command_with_zero_feedforward_stops_the_arm():
    arm = SimulatedArm(time_constant_s=0.05, initial_position_rad=HOME)
    v = np.zeros(7)
    v[0] = 1.0
    for k in range(1, 30):
        arm.set_target(HOME + v * k * 0.01, v)
        arm.step(0.01)
    final = arm.state.position_rad.copy()
    arm.set_target(final, np.zeros(7))  # the trajectory has come to rest where the arm is
    arm.step(0.01)
    assert np.max(np.abs(arm.state.velocity_rad_s)) < 1e-9


def test_velocity_above_limit_rejected(gate):
    reason = gate.offer(["right_s0"], [0.0], 0.0, HOME, velocity_rad_s=[2.0])
    assert reason is not None and "exceeds the joint's limit 1.50 rad/s" in reason
    reason = gate.offer(["right_s0", "right_s1"], [0.0, -0.5], 0.0, HOME, velocity_rad_s=[0.1])
    assert reason is not None and "2 names but 1 velocities" in reason


def test_feedforward_passed_through_and_zero_for_unnamed_joints(gate):
    assert gate.offer(["right_s0", "right_w2"], [0.1, 0.2], 0.0, HOME, velocity_rad_s=[0.3, -0.4]) is None
    d = gate.decide(0.01)
    assert d.feedforward_rad_s.tolist() == [0.3, 0, 0, 0, 0, 0, -0.4]


# --------------------------------------------------------------------------- StopBrake

from services.bridge.core import StopBrake  # noqa: E402


def test_brake_decelerates_every_joint_at_its_limit_then_rests():
    brake = StopBrake(deceleration_rad_s2=40.0)
    brake.engage("release", np.array([1.0, -0.5, 0.0, 0.2, 0.0, 0.0, 0.0]))
    speeds = [brake.step(0.01) for _ in range(4)]
    # 0.4 rad/s less per 10 ms tick, never past zero, signs kept.
    assert speeds[0] == pytest.approx([0.6, -0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert speeds[1] == pytest.approx([0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert speeds[2] == pytest.approx([0.0] * 7) and brake.at_rest
    # From 1 rad/s: at rest after ceil(1 / 0.4) = 3 ticks = 25 ms of braking at 40 rad/s².


def test_only_a_goal_sent_after_the_stop_ends_it():
    brake = StopBrake()
    assert brake.admit("reach-1")
    brake.engage("release", np.zeros(7))
    # reach-2 was sent before the stop; its commands arrive after it: ignored.
    assert not brake.admit("reach-1") and not brake.admit("reach-2")
    assert brake.ignored_commands == 2 and brake.active
    brake.goal_after_stop("retract-3")
    assert not brake.admit("reach-2")
    assert brake.admit("retract-3") and not brake.active
    assert brake.admit("anything")  # no stop: commands pass


def test_a_goal_sent_before_the_stop_but_arriving_after_it_does_not_end_the_stop():
    s = 1_000_000_000
    brake = StopBrake()
    brake.engage("release", np.zeros(7), source="supervisor", stamp_ns=100 * s)
    # A copy of the reach goal, sent before the stop and delayed on the bus, arrives now.
    brake.goal_after_stop("reach-2", "supervisor", 99 * s)
    assert not brake.admit("reach-2") and brake.active and brake.stale_goals == 1
    brake.goal_after_stop("retract-3", "supervisor", 101 * s)  # sent after the stop
    assert brake.admit("retract-3") and not brake.active
    # Another source's clock is not compared: its goal counts by arrival, as before.
    brake.engage("launcher stop", np.zeros(7), source="launcher", stamp_ns=500 * s)
    brake.goal_after_stop("g", "supervisor", 102 * s)
    assert brake.admit("g")


def test_a_protective_stop_is_latched_until_a_new_episode():
    brake = StopBrake()
    brake.engage("protective stop: gripper lost", np.zeros(7), protective=True)
    brake.goal_after_stop("retract-9")
    assert not brake.admit("retract-9") and brake.active
    brake.new_episode()
    brake.goal_after_stop("e2-pick-1")
    assert brake.admit("e2-pick-1") and not brake.active


def test_brake_rejects_a_non_positive_deceleration():
    with pytest.raises(ValueError, match="deceleration"):
        StopBrake(0.0)
