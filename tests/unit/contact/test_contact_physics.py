"""Physics of the contact plant against hand calculations."""

from __future__ import annotations

import math
import numpy as np
import pytest

from robot_sim.contact.config import GRAVITY_M_S2, GripperParams, ObjectParams
from robot_sim.contact.controllers import ConstantGrip, ReleaseAfter
from robot_sim.contact.episode import run_episode
from handover_model.grip import Mode
from robot_sim.contact.receiver import absent, bumping, dropping, hesitating, taking

from tests.unit.contact.helpers import StepGrip, quiet_config

M = 0.2
W = M * GRAVITY_M_S2
MU_S, MU_K = 0.6, 0.5
THRESHOLD_N = W / MU_S  # 3.27 N


@pytest.mark.parametrize("factor", [1.01, 1.2, 3.0, 20.0])
def test_held_object_stays_put_above_w_over_mu_s(factor):
    cfg = quiet_config(duration_s=1.0)
    res = run_episode(cfg, absent(), ConstantGrip(factor * THRESHOLD_N), seed=0)
    tr = res.trace
    assert np.all(tr.mode == Mode.GRASP)
    assert np.max(np.abs(tr.object_position_y_m)) == 0.0
    assert np.max(np.abs(tr.object_position_x_m)) == 0.0
    # The pads carry exactly the weight.
    assert tr.sensed_force_y_n[-1] == pytest.approx(W, abs=1e-9)


@pytest.mark.parametrize("factor", [0.99, 0.9, 0.5])
def test_object_slides_below_w_over_mu_s_with_kinetic_acceleration(factor):
    cfg = quiet_config(duration_s=0.08)  # short enough to stay within the 3 cm pads
    f = factor * THRESHOLD_N
    tr = run_episode(cfg, absent(), ConstantGrip(f), seed=0).trace
    accel = (W - MU_K * f) / M  # hand calculation, kinetic friction
    assert np.all(tr.mode[1:] == Mode.SLIP)
    # Symplectic Euler: y_n = a dt^2 n(n+1)/2 exactly while the force is constant.
    n = len(tr) - 1
    dt = cfg.dt_s
    assert tr.object_position_y_m[-1] == pytest.approx(accel * dt * dt * n * (n + 1) / 2, rel=1e-9)
    assert tr.object_velocity_y_m_s[-1] == pytest.approx(accel * n * dt, rel=1e-9)
    assert tr.object_accel_y_m_s2[-1] == pytest.approx(accel, rel=1e-9)


def test_sliding_decelerates_and_resticks_when_friction_exceeds_load():
    # Slide under 3 N (W/mu_s = 3.27 N), then grip 8 N: mu_k*8 = 4 N > W decelerates,
    # mu_s*8 = 4.8 N > W holds once the slip velocity is zero.
    cfg = quiet_config(duration_s=1.0)
    tr = run_episode(cfg, absent(), StepGrip(3.0, 8.0, 0.01), seed=0).trace
    fg = tr.grip_force_n
    slip = tr.mode == Mode.SLIP
    # In every slipping step, the true acceleration is g - mu_k F_G / M (velocity > 0, down).
    moving = slip & (tr.object_velocity_y_m_s > 0) & (np.roll(tr.object_velocity_y_m_s, 1) > 0)
    moving[0] = False
    np.testing.assert_allclose(tr.object_accel_y_m_s2[moving], GRAVITY_M_S2 - MU_K * fg[moving] / M,
                               rtol=1e-9, atol=1e-9)
    # It decelerated at some point, stopped, and stuck for good.
    assert np.any(tr.object_accel_y_m_s2[moving] < 0)
    stick_at = np.flatnonzero(slip)[-1] + 1
    assert np.all(tr.mode[stick_at:] == Mode.GRASP)
    assert np.all(tr.object_velocity_y_m_s[stick_at:] == 0.0)
    assert np.ptp(tr.object_position_y_m[stick_at:]) == 0.0
    # Re-stick happened where the grip force had risen above W / mu_k.
    assert fg[stick_at] * MU_K > W
    assert 0.0 < tr.object_position_y_m[-1] < cfg.obj.pad_extent_y_m


def test_no_restick_when_static_friction_cannot_hold():
    # mu_s = mu_k: with grip slightly above W/mu_k the slide decelerates, stops, and sticks;
    # with mu_s * F_G < W it never sticks even if velocity reaches zero.
    obj = ObjectParams(mu_static=0.5, mu_kinetic=0.5)
    cfg = quiet_config(duration_s=0.5, obj=obj)
    tr = run_episode(cfg, absent(), ConstantGrip(0.95 * W / 0.5), seed=0).trace
    assert not np.any(tr.mode[1:] == Mode.GRASP)


def test_free_fall_energy_and_momentum():
    cfg = quiet_config(duration_s=0.12, gripper=GripperParams(open_gap_m=0.02))
    tr = run_episode(cfg, absent(), ConstantGrip(0.0), seed=0).trace
    assert np.all(tr.mode == Mode.RELEASE)
    t = tr.time_s
    # Momentum: gravity's impulse only (M v = M g t), nothing along x.
    np.testing.assert_allclose(M * tr.object_velocity_y_m_s, M * GRAVITY_M_S2 * t, rtol=1e-12, atol=1e-15)
    assert np.all(tr.object_velocity_x_m_s == 0.0)
    # Energy: kinetic = potential lost, up to the integrator's O(dt / t) error.
    ke = 0.5 * M * tr.object_velocity_y_m_s[-1] ** 2
    pe = M * GRAVITY_M_S2 * tr.object_position_y_m[-1]
    assert ke == pytest.approx(pe, rel=2 * cfg.dt_s / t[-1])
    assert tr.object_position_y_m[-1] == pytest.approx(0.5 * GRAVITY_M_S2 * t[-1] ** 2, rel=2 * cfg.dt_s / t[-1])


def test_object_sliding_past_pad_extent_falls_even_if_grip_returns():
    # Weak grip: slides down at (W - mu_k F)/M; past 3 cm it leaves the pads. Re-grasping
    # with a large force afterwards must not stop it (the pads are no longer on it).
    cfg = quiet_config(duration_s=0.6)
    f = 1.0
    res = run_episode(cfg, absent(), StepGrip(f, 40.0, 0.3), seed=0)
    tr = res.trace
    a = (W - MU_K * f) / M
    t_leave = math.sqrt(2 * cfg.obj.pad_extent_y_m / a)
    out = tr.object_position_y_m > cfg.obj.pad_extent_y_m
    first_out = np.flatnonzero(out)[0]
    assert tr.time_s[first_out] == pytest.approx(t_leave, abs=3 * cfg.dt_s)
    after = np.arange(len(tr)) > first_out
    assert np.all(tr.mode[after] == Mode.RELEASE)
    np.testing.assert_allclose(tr.object_accel_y_m_s2[after], GRAVITY_M_S2, rtol=1e-9)
    assert res.outcome.dropped and not res.outcome.handed_over


def test_taking_with_fully_open_gripper_ends_in_receivers_hand():
    # The receiver grasps fully (1.0 s to 1.5 s), the gripper opens wide at 1.5 s, the
    # receiver pulls away from 1.8 s.
    beh = taking(pull_angle_rad=0.0, transfer_s=0.5, pull_delay_s=0.8)
    grasped_at = beh.grasp_start_s + beh.grasp_build_s  # the receiver's grasp is complete
    cfg = quiet_config(duration_s=3.0, gripper=GripperParams(open_gap_m=0.02))
    res = run_episode(cfg, beh, ReleaseAfter(10.0, grasped_at), seed=0)
    tr, out = res.trace, res.outcome
    assert out.released and out.handed_over and not out.dropped
    assert out.release_time_s >= grasped_at
    assert tr.receiver_holds[-1]
    # The object travelled with the hand: it sits in the hand (within the grasp's sag).
    assert tr.object_position_x_m[-1] == pytest.approx(tr.hand_position_x_m[-1], abs=0.01)
    assert abs(tr.object_position_y_m[-1] - tr.hand_position_y_m[-1]) < 0.01
    assert tr.object_position_x_m[-1] > 0.15


def test_dropping_receiver_drops_object_when_gripper_opens():
    beh = dropping(pull_angle_rad=0.0)
    cfg = quiet_config(duration_s=3.5, gripper=GripperParams(open_gap_m=0.02))
    out = run_episode(cfg, beh, ReleaseAfter(10.0, beh.grasp_start_s + 0.2), seed=0).outcome
    assert out.released and out.dropped and not out.handed_over


def test_dropping_against_strong_constant_grip_is_not_dropped():
    beh = dropping(pull_angle_rad=0.0, grasp_strength_n=8.0)
    cfg = quiet_config(duration_s=3.5)
    out = run_episode(cfg, beh, ConstantGrip(30.0), seed=0).outcome
    # mu_s * 30 = 18 N > the 8 N the receiver's grasp can transmit: never slips.
    assert not out.dropped and not out.released
    assert out.mode_switch_count == 0
    assert out.force_overshoot_n == pytest.approx(8.0, abs=0.05)


def test_actuator_delay_and_rate_limit():
    # Command a step 20 N -> 0 N at t = 0.5 s with the receiver absent and the object held
    # by a hand-free... measure the true grip force: it falls at <= k * v_max = 50 N/s and
    # starts no later than one 25 Hz loop period after the command.
    cfg = quiet_config(duration_s=1.0, obj=ObjectParams(mu_static=0.6, mu_kinetic=0.5))
    tr = run_episode(cfg, absent(), StepGrip(20.0, 30.0, 0.5), seed=0).trace
    fg = tr.grip_force_n
    rate = np.diff(fg) / cfg.dt_s
    assert rate.max() <= 500.0 * 0.1 + 1e-6
    first_move = np.flatnonzero(np.abs(np.diff(fg)) > 0)[0] + 1
    assert 0.5 <= tr.time_s[first_move] <= 0.5 + 0.04 + cfg.dt_s
    assert fg[-1] == pytest.approx(30.0, abs=0.01)
    # 10 N at 50 N/s takes at least 0.2 s.
    reach = np.flatnonzero(fg >= 29.99)[0]
    assert tr.time_s[reach] - 0.5 >= 0.2


def test_bump_makes_a_short_slip_then_the_grasp_holds_again():
    cfg = quiet_config(duration_s=2.0)
    res = run_episode(cfg, bumping(), ConstantGrip(10.0), seed=0)
    out, tr = res.outcome, res.trace
    modes = [m for _, m in out.mode_timeline]
    assert modes == [Mode.GRASP, Mode.SLIP, Mode.GRASP]
    slip_time = out.mode_timeline[2][0] - out.mode_timeline[1][0]
    assert slip_time < 0.15  # a short event
    assert tr.object_position_x_m[-1] < 0.0  # pushed toward the robot (phi = 180 deg)
    assert not out.released and not out.dropped
    # The collision pushed harder than the static friction limit mu_s * F_G = 6 N.
    assert out.force_overshoot_n > 6.0


def test_hesitating_receiver_never_holds_the_load():
    cfg = quiet_config(duration_s=3.0)
    beh = hesitating()
    held = run_episode(cfg, beh, ConstantGrip(10.0), seed=0)
    assert not held.outcome.released and not held.outcome.dropped
    assert not held.trace.receiver_holds[-1]
    # The thesis's failure: the giver lets go while the receiver hesitates -> dropped.
    let_go = run_episode(cfg, beh, ReleaseAfter(10.0, beh.grasp_start_s + 0.2), seed=0)
    assert let_go.outcome.dropped and not let_go.outcome.handed_over


def test_taking_handover_sags_little_when_the_receiver_carries_the_weight():
    beh = taking(pull_angle_rad=0.0, transfer_s=0.5, pull_delay_s=0.8)
    cfg = quiet_config(duration_s=3.0, gripper=GripperParams(open_gap_m=0.02))
    tr = run_episode(cfg, beh, ReleaseAfter(10.0, 1.5), seed=0).trace
    # Weight feedforward + grasp spring: sag below W / k_grasp + W / k_hand (1.3 mm + 4.9 mm).
    assert np.max(tr.object_position_y_m) < W / 1500.0 + W / 400.0


def test_real_time_advance_api():
    from robot_sim.contact.config import ContactSimError
    from robot_sim.contact.plant import ContactPlant

    cfg = quiet_config()
    plant = ContactPlant(cfg, absent(), seed=0, initial_grip_force_n=10.0)
    obs = plant.advance(0.01, 10.0)
    assert obs.time_s == pytest.approx(0.01) and plant.step_index == 10
    assert obs.ft_fresh and obs.optical_fresh  # 100 Hz sensors: one new sample per 10 ms
    assert isinstance(obs.wrist_force_y_n, float) and obs.wrist_force_y_n == pytest.approx(W)
    assert obs.mode == Mode.GRASP and obs.grip_force_n == pytest.approx(10.0)
    obs = plant.advance(0.004, 10.0)
    assert not obs.ft_fresh  # no F/T sample between 10 ms and 14 ms
    sample = plant.sensor_sample()
    assert sample.force_y_n.shape == (1,) and sample.time_s == pytest.approx(0.014)
    with pytest.raises(ContactSimError, match="grip_command_n"):
        plant.advance(0.01, float("nan"))
    assert plant.step_index == 14  # nothing changed
