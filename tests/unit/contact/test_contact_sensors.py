"""Sensor models checked against independent calculations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_sim.contact.actuator import GripperActuator
from robot_sim.contact.backend import NoiseSource, NumpyBackend, ScalarBackend
from robot_sim.contact.config import GripperParams, SensorParams
from robot_sim.contact.controllers import ConstantGrip
from robot_sim.contact.episode import run_episode
from robot_sim.contact.receiver import absent, taking
from robot_sim.contact.sensors import OpticalMotionSensor, WristForceSensor

from tests.unit.contact.helpers import quiet_config

COUNT_M = 0.0254 / 400.0  # one count at 400 cpi


def _optical(params: SensorParams, n: int = 1, seed: int = 0):
    xp = NumpyBackend
    return OpticalMotionSensor(params, xp, n, NoiseSource(np.random.default_rng(seed), n, True))


def test_optical_counts_are_whole_and_carry_the_remainder():
    p = SensorParams(optical_report_rate_hz=100.0)
    s = _optical(p)
    speed = 0.0123  # m/s along y, trackable
    dt = 0.001
    total_counts = 0.0
    per_read = []
    for k in range(1, 501):
        s.accumulate(np.array([0.0]), np.array([speed * dt]), np.array([speed]), np.array([True]))
        if k % 10 == 0:
            s.report(np.array([True]))
            c = float(s.counts_y[0])
            assert c == math.floor(c)
            total_counts += c
            per_read.append(c)
            # The velocity estimate is the counts over the report period.
            assert s.velocity_y_m_s[0] == pytest.approx(c * COUNT_M / 0.01, rel=1e-12)
    true_counts = speed * 0.5 / COUNT_M  # 242.1 counts
    assert total_counts == math.floor(true_counts)
    # Per-read counts are the floor or the ceil of 12.3 mm/s * 10 ms / 63.5 um = 1.94.
    assert set(per_read) == {1.0, 2.0}


def test_optical_quantisation_of_velocity_and_acceleration_estimates():
    p = SensorParams(optical_report_rate_hz=100.0)
    s = _optical(p)
    v_per_count = COUNT_M / 0.01  # 6.35 mm/s per count at 100 Hz
    a_per_count = v_per_count / 0.01  # 0.635 m/s^2 per count difference
    for v in (0.05, 0.1, 0.0):
        for _ in range(10):
            s.accumulate(np.array([0.0]), np.array([v * 0.001]), np.array([v]), np.array([True]))
        s.report(np.array([True]))
        assert (s.velocity_y_m_s[0] / v_per_count) == pytest.approx(round(s.velocity_y_m_s[0] / v_per_count), abs=1e-9)
        assert (s.accel_y_m_s2[0] / a_per_count) == pytest.approx(round(s.accel_y_m_s2[0] / a_per_count), abs=1e-9)


def test_optical_register_range_clips_and_loses_the_excess():
    p = SensorParams(optical_report_rate_hz=10.0, optical_max_disp_per_frame_m=1.0)  # no speed limit
    s = _optical(p)
    s.accumulate(np.array([300 * COUNT_M]), np.array([-300 * COUNT_M]), np.array([0.1]), np.array([True]))
    s.report(np.array([True]))
    assert s.counts_x[0] == 127 and s.counts_y[0] == -128
    s.report(np.array([True]))  # the excess is gone, not reported later
    assert s.counts_x[0] == 0 and s.counts_y[0] == 0


def test_optical_loses_track_above_its_speed_limit():
    p = SensorParams()
    vmax = p.optical_max_speed_m_s
    assert vmax == pytest.approx(14 * 0.0254, rel=1e-12)  # ADNS-2051: 14 in/s
    s = _optical(p, n=2)
    speeds = np.array([0.9 * vmax, 1.1 * vmax])
    for _ in range(10):
        s.accumulate(np.zeros(2), speeds * 0.001, speeds, np.array([True, True]))
    s.report(np.array([True, True]))
    assert s.counts_y[0] == math.trunc(0.9 * vmax * 0.01 / COUNT_M + 1e-9)
    assert s.counts_y[1] == 0


def test_optical_reads_nothing_without_surface():
    s = _optical(SensorParams(), n=2)
    for _ in range(10):
        s.accumulate(np.zeros(2), np.full(2, 1e-4), np.full(2, 0.1), np.array([True, False]))
    s.report(np.array([True, False]))
    assert s.counts_y[0] > 0 and s.counts_y[1] == 0
    assert list(s.valid) == [True, False]
    assert s.accel_y_m_s2[1] == 0.0


def test_optical_gap_over_4mm_makes_it_blind_in_an_episode():
    # Gripper fully open (2 cm gap): the sensor never sees the falling object.
    cfg = quiet_config(duration_s=0.1, gripper=GripperParams(open_gap_m=0.02))
    tr = run_episode(cfg, absent(), ConstantGrip(0.0), seed=0).trace
    # The finger backs off at 0.1 m/s after the first 25 Hz tick: 4 mm after ~40 ms more.
    blind = np.flatnonzero(~tr.optical_valid)[0]
    assert 0.03 <= tr.time_s[blind] <= 0.07
    assert not tr.optical_valid[blind:].any()
    assert np.all(tr.accel_estimate_y_m_s2[blind:] == 0.0)
    # Thesis gripper (touching at zero force, gap 0): it sees the object slide and reads ~g.
    cfg = quiet_config(duration_s=0.07,
                       sensors=SensorParams(ft_noise_std_n=0.0, ft_bias_std_n=0.0, optical_report_rate_hz=100.0))
    tr = run_episode(cfg, absent(), ConstantGrip(0.0), seed=0).trace
    assert tr.optical_valid.all()
    i30 = int(np.flatnonzero(np.isclose(tr.time_s, 0.03))[0])
    # Two velocity estimates, each within one count (6.35 mm/s): a within 2 * 0.635 m/s^2.
    assert abs(tr.accel_estimate_y_m_s2[i30] - 9.81) <= 2 * 0.635 + 1e-9
    # Free fall passes the sensor's 0.356 m/s at 36 ms: by 60 ms it reads no motion at all.
    i60 = int(np.flatnonzero(np.isclose(tr.time_s, 0.06))[0])
    assert tr.accel_estimate_y_m_s2[i60] == 0.0


def test_optical_report_rate():
    cfg = quiet_config(duration_s=0.2, gripper=GripperParams(open_gap_m=0.0),
                       sensors=SensorParams(ft_noise_std_n=0.0, ft_bias_std_n=0.0, optical_report_rate_hz=250.0))
    tr = run_episode(cfg, absent(), ConstantGrip(0.0), seed=0).trace
    changes = np.flatnonzero(np.diff(tr.accel_estimate_y_m_s2) != 0) + 1
    steps = np.round(tr.time_s[changes] / 0.004, 9)
    assert np.all(steps == np.round(steps))  # only at the 4 ms report ticks


def test_wrist_sensor_rate_bias_and_noise():
    sp = SensorParams(ft_rate_hz=100.0, ft_noise_std_n=0.05, ft_bias_std_n=0.0, ft_bias_n=0.3)
    cfg = quiet_config(duration_s=2.0, sensors=sp)
    tr = run_episode(cfg, absent(), ConstantGrip(10.0), seed=7).trace
    fy = tr.sensed_force_y_n
    changes = np.flatnonzero(np.diff(fy) != 0) + 1
    ticks = tr.time_s[changes] / 0.01
    np.testing.assert_allclose(ticks, np.round(ticks), atol=1e-9)  # 100 Hz only
    samples = fy[changes]
    assert len(samples) == pytest.approx(200, abs=1)
    w = cfg.obj.weight_n
    assert np.mean(samples) == pytest.approx(w + 0.3, abs=4 * 0.05 / math.sqrt(len(samples)))
    assert np.std(samples) == pytest.approx(0.05, rel=0.2)


def test_wrist_bias_is_drawn_per_episode():
    sp = SensorParams(ft_bias_std_n=0.5, ft_noise_std_n=0.0)
    biases = []
    for seed in range(200):
        s = WristForceSensor(sp, ScalarBackend, 1, NoiseSource(np.random.default_rng(seed), 1, False))
        biases.append(s.bias_x_n)
    assert np.std(biases) == pytest.approx(0.5, rel=0.2)
    assert abs(np.mean(biases)) < 4 * 0.5 / math.sqrt(200)


def test_snr_3db_noise_power_is_half_the_signal_power():
    # Constant clean estimate: SNR 3 dB means noise power = signal power / 10^0.3.
    p = SensorParams(optical_report_rate_hz=100.0, accel_noise_snr_db=3.0)
    n = 4000
    s = _optical(p, n=n, seed=3)
    v = 0.0
    a_true = 2.0
    ests = []
    for r in range(12):
        v_next = v + a_true * 0.01
        for _ in range(10):
            s.accumulate(np.zeros(n), np.full(n, v_next * 0.001), np.full(n, v_next), np.ones(n, dtype=bool))
        v = v_next
        s.report(np.ones(n, dtype=bool))
        ests.append(s.accel_y_m_s2.copy())
    # Independent expectation: the clean estimate is the count-quantised a_true, identical
    # in every episode; noise power = its mean square so far / 10^(3/10).
    clean_now = np.median(ests[-1])
    assert abs(clean_now - a_true) <= 0.635 + 1e-9
    noise = ests[-1] - np.mean(ests[-1])
    clean_hist = [np.median(e) for e in ests]  # medians recover the clean value per report
    expected_var = np.mean(np.square(clean_hist)) / 10 ** 0.3
    assert np.var(noise) == pytest.approx(expected_var, rel=0.15)


def test_actuator_force_follows_eq_3_21():
    gp = GripperParams()
    act = GripperActuator(gp, 0.001, ScalarBackend, 1, 0.0)
    for x_cmd_m, force in ((0.01, 5.0), (0.04, 20.0)):
        act.latch(force)
        for _ in range(2000):
            act.move()
        assert act.finger_m == pytest.approx(x_cmd_m, abs=1e-9)
        assert act.spring_force_n() == pytest.approx(500.0 * x_cmd_m, abs=1e-6)  # k = 5 N/cm
    act.latch(0.0)
    for _ in range(2000):
        act.move()
    assert act.spring_force_n() == 0.0


def test_taking_episode_optical_sees_slip():
    cfg = quiet_config(duration_s=2.5)
    tr = run_episode(cfg, taking(), ConstantGrip(10.0), seed=0).trace
    assert tr.optical_valid[0]
    assert not tr.optical_valid[-1]  # the object has left the pads with the receiver
