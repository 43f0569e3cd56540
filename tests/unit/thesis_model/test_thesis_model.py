"""Thesis model mode (eqs 3.1–3.4) against hand-computed cases and the §3.5 scenarios."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from handover_model.grip import Mode
from robot_sim.thesis_model import ThesisModelError, ThesisScenario, simulate, step_model
from services.gripper.controllers.registry import make_controller


def test_grasp_case_by_hand():
    # W = 2, pull 1 at φ = 0: F_sum = sqrt(5) = 2.236 ≤ μs F_G = 3 -> grasp, F_s = L, a = 0
    mode, fx, fy, ax, ay = step_model(np.array([5.0]), 1.0, 0.0, 2.0, 0.2, 0.6, 0.5)
    assert mode[0] == Mode.GRASP
    assert (fx[0], fy[0], ax[0], ay[0]) == pytest.approx((1.0, 2.0, 0.0, 0.0))


def test_slip_case_by_hand():
    # F_G = 3: μs F_G = 1.8 < 2.236 -> slip; F_f = 1.5 along (1, 2)/sqrt 5; |a| = (sqrt5 − 1.5)/0.2
    mode, fx, fy, ax, ay = step_model(np.array([3.0]), 1.0, 0.0, 2.0, 0.2, 0.6, 0.5)
    r5 = math.sqrt(5.0)
    assert mode[0] == Mode.SLIP
    assert fx[0] == pytest.approx(1.5 / r5) and fy[0] == pytest.approx(3.0 / r5)
    mag = (r5 - 1.5) / 0.2
    assert ax[0] == pytest.approx(mag / r5) and ay[0] == pytest.approx(2 * mag / r5)


def test_release_case_by_hand():
    mode, fx, fy, ax, ay = step_model(np.array([0.0]), 1.0, 0.0, 2.0, 0.2, 0.6, 0.5)
    assert mode[0] == Mode.RELEASE and fx[0] == 0.0 and fy[0] == 0.0
    assert (ax[0], ay[0]) == pytest.approx((5.0, 10.0))


def test_slip_satisfies_eq_3_4_for_random_inputs():
    rng = np.random.default_rng(0)
    n = 500
    grip = rng.uniform(0.1, 3, n)
    pull = rng.uniform(0, 5, n)
    phi = rng.uniform(-1.2, 1.2, n)
    w, m, mus, muk = 2.0, 0.2, 0.6, 0.5
    mode, fx, fy, ax, ay = step_model(grip, pull, phi, w, m, mus, muk)
    s = mode == Mode.SLIP
    assert s.sum() > 100
    np.testing.assert_allclose(pull[s] * np.cos(phi[s]) - fx[s], m * ax[s], atol=1e-12)  # eq 3.4 x
    np.testing.assert_allclose(w + pull[s] * np.sin(phi[s]) - fy[s], m * ay[s], atol=1e-12)  # eq 3.4 y
    np.testing.assert_allclose(np.hypot(fx[s], fy[s]), muk * grip[s], atol=1e-12)  # F_f = μk F_G
    np.testing.assert_allclose(ay[s] * fx[s], ax[s] * fy[s], atol=1e-9)  # a_y/a_x = tan θ


def test_scenario_profiles():
    drop = ThesisScenario(action="dropping")
    np.testing.assert_allclose(drop.pull_n(np.array([0.5, 1.25, 1.5, 2.0, 2.5, 3.0])), [0, 1, 2, 2, 0, 0])
    take = ThesisScenario(action="taking", weight_delay_s=0.1, weight_transfer_s=0.5)
    w = take.weight_n
    np.testing.assert_allclose(take.weight_on_gripper_n(np.array([1.0, 1.1, 1.35, 1.6, 3.0])), [w, w, w / 2, 0, 0])
    np.testing.assert_allclose(take.pull_n(np.array([3.0])), [2.0])
    assert np.all(drop.weight_on_gripper_n(np.array([0.0, 3.0])) == drop.weight_n)


@pytest.mark.parametrize("bad", [dict(action="throwing"), dict(mass_kg=0.0), dict(mu_kinetic=0.7),
                                 dict(ramp_end_s=0.5), dict(phi_rad=2.0), dict(noise_reference="rms")])
def test_bad_scenarios(bad):
    with pytest.raises(ThesisModelError):
        ThesisScenario(**bad)


def test_batch_must_share_timing():
    with pytest.raises(ThesisModelError):
        simulate([ThesisScenario(), ThesisScenario(period_s=0.02)], make_controller("FS1"))


def test_fig20_behaviour_gamma5():
    run = simulate([ThesisScenario(action="taking"), ThesisScenario(action="dropping")], make_controller("FS-sim-g5"))
    t = run.time_s
    take, drop = run.mode[:, 0], run.mode[:, 1]
    assert np.all(take[t < 1.0] == Mode.GRASP) and take[-1] == Mode.RELEASE
    release_t = t[np.argmax(take == Mode.RELEASE)]
    assert 1.0 < release_t < 1.6
    assert not np.any(drop == Mode.RELEASE) and drop[-1] == Mode.GRASP
    assert np.any(drop == Mode.SLIP)
    assert run.accel_y_m_s2[:, 1].max() < 4.0
    # grip returns to its rest value α W − F_margin after the pull
    assert run.grip_force_n[-1, 1] == pytest.approx(10 * 0.2 * 9.81 - 12, rel=1e-3)


def test_gamma1_does_not_slip_at_two_newtons():
    run = simulate(ThesisScenario(action="dropping"), make_controller("FS-sim-g1"))
    assert np.all(run.mode == Mode.GRASP)  # F_p = 2 N < F_ST(0) = 2.42 N


def test_batch_equals_single_runs_and_seeded_repeatability():
    scs = [ThesisScenario(action="dropping", accel_noise_snr_db=3.0, seed=5),
           ThesisScenario(action="taking", phi_rad=0.3, grip_noise_snr_db=10.0, seed=6)]
    batch = simulate(scs, make_controller("FS1"))
    again = simulate(scs, make_controller("FS1"))
    np.testing.assert_array_equal(batch.grip_force_n, again.grip_force_n)
    for j, sc in enumerate(scs):
        single = simulate(sc, make_controller("FS1"))
        np.testing.assert_array_equal(single.accel_y_measured_m_s2[:, 0], batch.accel_y_measured_m_s2[:, j])
        np.testing.assert_array_equal(single.mode[:, 0], batch.mode[:, j])
    other = simulate([replace(scs[0], seed=7)], make_controller("FS1"))
    assert not np.array_equal(other.accel_y_measured_m_s2[:, 0], batch.accel_y_measured_m_s2[:, 0])


def test_noise_level_matches_snr():
    sc = ThesisScenario(action="dropping", accel_noise_snr_db=6.0, seed=1, duration_s=40.0, pull_end_s=30.0)
    clean = simulate(replace(sc, accel_noise_snr_db=None), make_controller("FS-sim-g5"))
    noisy = simulate(sc, make_controller("FS-sim-g5"))
    power = np.mean(clean.accel_y_m_s2[:, 0] ** 2)
    noise = noisy.accel_y_measured_m_s2[:, 0] - noisy.accel_y_m_s2[:, 0]
    assert np.var(noise) == pytest.approx(power / 10 ** 0.6, rel=0.1)
