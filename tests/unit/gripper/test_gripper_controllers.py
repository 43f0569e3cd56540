"""Each release law against hand-computed steps."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model.grip import GripController, Mode
from services.gripper.controllers.baselines import DisplacementRelease, ForceThresholdRelease, TimedRelease
from services.gripper.controllers.fail_safe import FS_PRESETS, FailSafeController, FailSafeParams, fail_safe_law
from services.gripper.controllers.human_inspired import (
    HumanInspiredController,
    HumanInspiredParams,
    human_inspired_grip_n,
)
from services.gripper.controllers.registry import CONTROLLER_NAMES, make_controller
from services.gripper.errors import GripperError
from tests.unit.gripper.helpers import sample


def test_fs_law_one_step_by_hand():
    # FS1: 10*2 + 3*3 - 3*1 - 15 = 11 ; 0.13*11 + 0.87*8 = 8.39
    out = fail_safe_law(FS_PRESETS["FS1"], 1.0, 2.0, 3.0, 8.0)
    assert out == pytest.approx(8.39, abs=1e-12)


def test_fs_law_clamps_to_zero_and_fmax():
    p = FS_PRESETS["FS1"]
    assert fail_safe_law(p, 10.0, 0.0, 0.0, 0.0) == 0.0  # 0.13*(-45) < 0
    big = FailSafeParams(alpha=100.0, k_i=1.0, max_grip_force_n=50.0)
    assert fail_safe_law(big, 0.0, 10.0, 0.0, 0.0) == 50.0


def test_presets_match_thesis():
    assert (FS_PRESETS["FS1"].alpha, FS_PRESETS["FS1"].gamma, FS_PRESETS["FS1"].f_margin_n) == (10, 3, 15)
    assert FS_PRESETS["FS2"].alpha == 15 and FS_PRESETS["FS2"].gamma == 3
    assert FS_PRESETS["FS3"].alpha == 10 and FS_PRESETS["FS3"].gamma == 1
    assert FS_PRESETS["FS-sim-g1"].gamma == 1 and FS_PRESETS["FS-sim-g5"].gamma == 5
    assert all(p.k_i == 0.13 and p.beta == 3 for p in FS_PRESETS.values())
    assert FS_PRESETS["FS-sim-g5"].f_margin_n == 12


def test_fs_controller_starts_at_rest_fixed_point_then_follows_law():
    c = FailSafeController(FS_PRESETS["FS-sim-g5"])
    c.reset(1)
    w = 0.2 * 9.81
    first = c.step(sample(fx=0.0, fy=w))
    assert first[0] == pytest.approx(10 * w - 12, abs=1e-12)  # fixed point α W − F_margin
    second = c.step(sample(fx=1.0, fy=w, ay=2.0))
    expected = 0.13 * (10 * w + 3 * 2.0 - 5 * 1.0 - 12) + 0.87 * (10 * w - 12)
    assert second[0] == pytest.approx(expected, abs=1e-12)


def test_fs_controller_vectorised_equals_scalar_loop():
    rng = np.random.default_rng(3)
    n, steps = 50, 30
    p = replace_init(FS_PRESETS["FS1"], 6.0)
    batch = FailSafeController(p)
    batch.reset(n)
    state = np.full(n, 6.0)
    for k in range(steps):
        fx, fy, ay = rng.normal(1, 2, n), rng.normal(2, 1, n), rng.normal(0, 3, n)
        got = batch.step(sample(time_s=k * 0.01, fx=fx, fy=fy, ay=ay))
        for i in range(n):  # plain-Python reference of eq 3.19
            raw = 0.13 * (10 * fy[i] + 3 * ay[i] - 3 * fx[i] - 15) + 0.87 * state[i]
            state[i] = min(max(raw, 0.0), 140.0)
        np.testing.assert_allclose(got, state, rtol=0, atol=1e-12)


def replace_init(params, value):
    from dataclasses import replace

    return replace(params, initial_grip_force_n=value)


def test_fs_mode_estimate():
    c = FailSafeController(replace_init(FS_PRESETS["FS1"], 5.0))
    c.reset(3)
    c.step(sample(fx=[0.0, 0.0, 50.0], fy=[2.0, 2.0, 0.0], ay=[0.0, 3.0, 0.0]))
    assert list(c.mode) == [Mode.GRASP, Mode.SLIP, Mode.RELEASE]


def test_hi_law_by_hand():
    p = HumanInspiredParams()  # F_Go 15, ε −2, F_ZLG 5 ; F_Lo = 2 → m = 5
    loads = np.array([2.0, 1.0, 0.0, -1.0, -2.0, -3.0])
    np.testing.assert_allclose(human_inspired_grip_n(p, loads, 2.0), [15, 10, 5, 5, 0, 0])


def test_hi_controller_learns_initial_load_and_latches_release():
    c = HumanInspiredController()
    c.reset(1)
    assert c.step(sample(fy=2.0))[0] == pytest.approx(15.0)
    assert c.step(sample(fy=1.0))[0] == pytest.approx(10.0)
    assert c.step(sample(fy=-2.5))[0] == 0.0
    assert c.step(sample(fy=2.0))[0] == 0.0  # latched
    assert c.mode[0] == Mode.RELEASE


def test_hi_rejects_no_initial_load():
    c = HumanInspiredController()
    c.reset(1)
    with pytest.raises(GripperError, match="initial_load_n"):
        c.step(sample(fy=0.0))


def test_timed_release():
    c = TimedRelease(release_time_s=1.0, hold_force_n=12.0)
    c.reset(2)
    assert list(c.step(sample(time_s=0.99, n=2))) == [12.0, 12.0]
    assert list(c.step(sample(time_s=1.0, n=2))) == [0.0, 0.0]


def test_force_threshold_release_uses_change_from_rest():
    c = ForceThresholdRelease(threshold_n=3.0)
    c.reset(3)
    c.step(sample(fx=[0, 0, 0], fy=[2, 2, 2]))
    out = c.step(sample(fx=[2.9, 3.0, 0.0], fy=[2.0, 2.0, -1.0]))  # |Δ| = 2.9, 3.0, 3.0
    assert list(out) == [15.0, 0.0, 0.0]
    out = c.step(sample(fx=[0, 0, 0], fy=[2, 2, 2]))
    assert list(out) == [15.0, 0.0, 0.0]  # latched


def test_displacement_release_first_step_and_statics():
    c = DisplacementRelease(displacement_threshold_m=0.01, stiffness_n_m=300.0, mass_kg=2.0, damping_ratio=1.0)
    c.reset(2)
    c.step(sample(fx=[0, 0], fy=[2, 2]))
    c.step(sample(fx=[6.0, 2.0], fy=[2, 2]))
    # semi-implicit Euler from rest: v = dt F/M, x = dt v
    np.testing.assert_allclose(c.position_m[0], [0.01 * 0.01 * 6 / 2, 0.01 * 0.01 * 2 / 2])
    for _ in range(300):  # 3 s: critically damped, settles at F/K = 0.02 m and 0.0067 m
        out = c.step(sample(fx=[6.0, 2.0], fy=[2, 2]))
    assert list(out) == [0.0, 15.0]
    assert c.position_m[0, 1] == pytest.approx(2.0 / 300.0, rel=1e-3)


def test_displacement_ignores_short_bump_that_force_threshold_does_not():
    disp, force = DisplacementRelease(), ForceThresholdRelease()
    for c in (disp, force):
        c.reset(1)
        c.step(sample(fx=0.0, fy=2.0))
        c.step(sample(fx=6.0, fy=2.0))  # one 10 ms bump of 6 N
        for _ in range(100):
            c.step(sample(fx=0.0, fy=2.0))
    assert disp.grip_force_n[0] == 15.0 and force.grip_force_n[0] == 0.0


@pytest.mark.parametrize("name", CONTROLLER_NAMES)
def test_registry_builds_protocol_objects(name):
    c = make_controller(name, period_s=0.04)
    assert isinstance(c, GripController) and c.period_s == 0.04
    c.reset(4)
    out = c.step(sample(time_s=0.0, fx=0.0, fy=2.0, n=4))
    assert out.shape == (4,) and np.all(out >= 0.0) and np.all(out <= 140.0)


def test_registry_errors():
    with pytest.raises(GripperError, match="unknown controller"):
        make_controller("FS9")
    with pytest.raises(GripperError, match="unknown parameter"):
        make_controller("FS1", alfa=3)
    with pytest.raises(GripperError, match="140"):
        make_controller("FS1", max_grip_force_n=200.0)
    with pytest.raises(GripperError, match="k_i"):
        FailSafeParams(k_i=1.5)


def test_step_before_reset_and_shape_mismatch():
    c = make_controller("FS1")
    with pytest.raises(GripperError, match="reset"):
        c.step(sample(fy=2.0))
    c.reset(3)
    with pytest.raises(GripperError, match="3"):
        c.step(sample(fx=[0.0, 0.0], fy=[2.0, 2.0]))
