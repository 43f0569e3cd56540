"""Analysis functions against independently derived values (closed forms, the model itself)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from handover_model.grip import Mode
from robot_sim.thesis_model import step_model
from services.studies.gripper import analysis as A
from services.gripper.controllers.fail_safe import FS_PRESETS
from services.gripper.errors import GripperError

PLANT = A.TABLE_IV_PLANT
W = 0.2 * 9.81


def fst_closed_form(phi, fs, plant):
    """Square eq 3.12: (1 − μ²c1²)F² + 2(W s − μ² c0 c1)F + (W² − μ² c0²) = 0, smallest root > 0
    with a non-negative right side."""
    w, mu = plant.weight_n, plant.mu_static
    s, c = math.sin(phi), math.cos(phi)
    c0 = fs.alpha * w - fs.f_margin_n
    c1 = fs.alpha * s - fs.gamma * c
    roots = np.roots([1 - mu**2 * c1**2, 2 * (w * s - mu**2 * c0 * c1), w**2 - mu**2 * c0**2])
    good = [r.real for r in roots if abs(r.imag) < 1e-12 and r.real > 0 and c0 + c1 * r.real >= 0]
    return min(good) if good else math.inf


@pytest.mark.parametrize("preset", ["FS1", "FS2", "FS3", "FS-sim-g1", "FS-sim-g5"])
@pytest.mark.parametrize("phi_deg", [-45.0, -20.0, 0.0, 5.0, 12.0])
def test_fst_matches_squared_closed_form(preset, phi_deg):
    fs = FS_PRESETS[preset]
    phi = math.radians(phi_deg)
    expected = fst_closed_form(phi, fs, PLANT)
    got = A.start_force_threshold_n(phi, fs, PLANT)
    if math.isinf(expected):
        assert math.isinf(got)
    else:
        assert got == pytest.approx(expected, rel=1e-9)


def test_fst_gamma5_by_hand_below_one_newton():
    # φ = 0: sqrt(F² + W²) = 0.6 (10 W − 5 F − 12); hand bisection gives 0.8157 N
    got = A.start_force_threshold_n(0.0, FS_PRESETS["FS-sim-g5"])
    assert got == pytest.approx(0.81573, abs=1e-4) and got < 1.0


def test_fst_is_where_the_model_starts_to_slip():
    """Independent check through the thesis model's own mode logic (eqs 3.2–3.4)."""
    fs = FS_PRESETS["FS1"]
    for phi_deg in (-30.0, 0.0, 15.0):
        phi = math.radians(phi_deg)
        f = A.start_force_threshold_n(phi, fs, PLANT)
        for pull, expected in ((f * (1 - 1e-6), Mode.GRASP), (f * (1 + 1e-6), Mode.SLIP)):
            grip = fs.alpha * (W + pull * math.sin(phi)) - fs.gamma * pull * math.cos(phi) - fs.f_margin_n  # eq 3.13
            mode = step_model(np.array([grip]), pull, phi, W, 0.2, 0.6, 0.5)[0]
            assert mode[0] == expected


def test_printed_equation_differs():
    fs = FS_PRESETS["FS2"]
    assert (A.start_force_threshold_n(0.0, fs, printed_equation=True)
            != pytest.approx(A.start_force_threshold_n(0.0, fs), rel=1e-3))


def test_phi_max_closed_form_and_asymptote():
    for preset in ("FS1", "FS2", "FS3", "FS-sim-g5"):
        fs = FS_PRESETS[preset]
        expected = math.atan2(fs.gamma, fs.alpha) + math.asin(1.0 / (PLANT.mu_static * math.hypot(fs.alpha, fs.gamma)))
        got = A.phi_max_rad(fs)
        assert got == pytest.approx(expected, abs=1e-10)
        assert math.isinf(A.start_force_threshold_n(got + 1e-3, fs))
        assert A.start_force_threshold_n(got - 1e-3, fs) > 50.0


def test_phi_max_for_pull_is_where_fst_reaches_the_cap():
    fs = replace(FS_PRESETS["FS-sim-g5"], gamma=3.0)
    phi = A.phi_max_for_pull_rad(5.0, fs)
    assert A.start_force_threshold_n(phi, fs) == pytest.approx(5.0, rel=1e-6)
    with pytest.raises(GripperError):
        A.phi_max_for_pull_rad(-1.0, fs)


def test_rest_condition_and_tolerated_accel_by_hand():
    fs = FS_PRESETS["FS-sim-g5"]
    assert A.rest_condition_alpha_min(fs, PLANT) == pytest.approx(1 / 0.6 + 12 / W)
    assert A.rest_condition_holds(fs, PLANT)
    assert not A.rest_condition_holds(replace(fs, alpha=7.0), PLANT)
    assert A.tolerated_accel_m_s2(fs) == pytest.approx(4.0)
    # rest condition failing -> F_ST = 0 (object slips unpulled)
    assert A.start_force_threshold_n(0.0, replace(fs, alpha=7.0)) == 0.0


def test_slip_pole_by_hand():
    fs = FS_PRESETS["FS-sim-g1"]
    # F_p -> 0: F_sum = W, a0 = μk (α − β/M) = 0.5 (10 − 15) = −2.5
    assert A.slip_pole(1e-12, 0.0, fs, with_integrator=False) == pytest.approx(-2.5)
    assert A.slip_pole(1e-12, 0.0, fs, with_integrator=True) == pytest.approx(0.13 * -2.5 + 0.87)


def fbt_closed_form(phi, fs, plant, target):
    """Solve μk N(F) = target · F_sum(F) by squaring: N = (W + F s) k − γ F c, k = α − β/M."""
    w, mu = plant.weight_n, plant.mu_kinetic
    s, c = math.sin(phi), math.cos(phi)
    k = fs.alpha - fs.beta / plant.mass_kg
    n0, n1 = w * k, s * k - fs.gamma * c
    t2 = target**2
    roots = np.roots([mu**2 * n1**2 - t2, 2 * mu**2 * n0 * n1 - t2 * 2 * w * s, mu**2 * n0**2 - t2 * w**2])
    return sorted(r.real for r in roots
                  if abs(r.imag) < 1e-9 and r.real > 0 and np.sign(mu * (n0 + n1 * r.real)) == np.sign(target))


def test_fbt_no_integrator_matches_closed_form():
    fs = FS_PRESETS["FS-sim-g1"]
    # φ = 0 by hand: 0.75 F² − 2.5 W F − 5.25 W² = 0 -> F = W (2.5 + sqrt(22)) / 1.5
    assert A.stable_force_threshold_n(0.0, fs, with_integrator=False) == pytest.approx(
        W * (2.5 + math.sqrt(22.0)) / 1.5, rel=1e-9)
    for phi_deg in (-30.0, -10.0, 5.0):
        phi = math.radians(phi_deg)
        roots = fbt_closed_form(phi, fs, PLANT, -1.0)
        assert A.stable_force_threshold_n(phi, fs, with_integrator=False) == pytest.approx(max(roots), rel=1e-8)


def test_fbt_gamma5_without_integrator_never_stable():
    assert math.isinf(A.stable_force_threshold_n(0.0, FS_PRESETS["FS-sim-g5"], with_integrator=False))


def test_fbt_with_integrator():
    fs = FS_PRESETS["FS-sim-g1"]
    np.testing.assert_array_equal(A.stable_force_threshold_n(np.radians([-30.0, 0.0, 30.0]), fs), [0.0, 0.0, 0.0])
    # steep upward pull: a0 -> μk (sinφ (α − β/M) − γ cosφ) = 0.5 (4.33 − 0.5) > 1 -> a > 1 at large pulls
    assert math.isinf(A.stable_force_threshold_n(math.radians(-60.0), fs))


def test_bad_plant():
    with pytest.raises(GripperError):
        A.ThesisPlant(mu_static=0.3, mu_kinetic=0.5)
    with pytest.raises(GripperError):
        A.ThesisPlant(mass_kg=float("nan"))
