"""The slip-guarded load-share controller (SG) against hand-computed steps.

The hand-computed steps of the law itself use the version 2 preset (`SG-v2`: c_hold = 4, no
hold cap, s_cap = 3), whose numbers they were written for; version 3 (the `SG` default:
c_hold = 5.5, F_hold capped at 20 N, s_cap = 1) has its own tests at the end."""

from __future__ import annotations

import numpy as np
import pytest

from services.gripper.controllers.registry import make_controller
from services.gripper.controllers.slip_guard import SlipGuardController, SlipGuardParams
from services.gripper.errors import GripperError
from tests.unit.gripper.helpers import sample


def sg(**kw) -> SlipGuardController:
    c = make_controller("SG-v2", **kw)
    c.reset(1)
    return c


def test_hold_scales_with_the_measured_weight_and_follows_the_load_share():
    c = sg()
    assert c.step(sample(fy=2.0))[0] == pytest.approx(4 * 2.0 + 1.0)  # c_hold W0 + F_min
    # share 0.65: level (0.65 − 0.5)/0.5 = 0.3, demand 0.3 · 9 = 2.7; k_down = 1: at once
    assert c.step(sample(fy=1.3))[0] == pytest.approx(2.7)
    assert c.mode[0] == 0  # grasp


def test_easing_off_with_a_smaller_step():
    c = sg(release_share=0.3, ease_off=0.3)
    c.step(sample(fy=2.0))
    # share 0.65: level (0.65 − 0.3)/0.7 = 0.5, demand 4.5; easing off: 9 + 0.3 (4.5 − 9)
    assert c.step(sample(fy=1.3))[0] == pytest.approx(7.65)


def test_a_slide_does_not_look_like_the_receiver_taking_the_load():
    # The object slides sideways out of a loaded grip: the wrist now reads kinetic friction
    # along the slide (F_sy 0.6 N, share 0.3), not the load. SG keeps the share seen one step
    # before the slide (1.0): g = 1 + 20 · 0.01 · (0.05 / 0.005) = 3, demand 3 · 9 = 27 N.
    c = sg()
    c.step(sample(fy=2.0))
    c.step(sample(fy=2.0))
    assert c.step(sample(fy=0.6, vx=0.05))[0] == pytest.approx(27.0)
    assert c.share_before_slip[0] == pytest.approx(1.0)
    # Without the memory the same reading is taken for a handover: demand 0, released.
    c = sg(slip_share_memory=False)
    c.step(sample(fy=2.0))
    c.step(sample(fy=2.0))
    assert c.step(sample(fy=0.6, vx=0.05))[0] == 0.0


def test_slip_while_loaded_raises_the_grip_at_once_and_remembers_it():
    c = sg()
    c.step(sample(fy=2.0))
    # |v| = 10 mm/s = 2 v_th: g = 1 + 20 · 0.01 · 2 = 1.4; demand 1.4 · 9 = 12.6, applied at once
    assert c.step(sample(fy=2.0, vx=0.01))[0] == pytest.approx(12.6)
    assert c.mode[0] == 1  # slip
    assert c.step(sample(fy=2.0))[0] == pytest.approx(12.6)  # the slip stopped: g is kept
    assert c.gain[0] == pytest.approx(1.4)


def test_no_adaptation_once_the_receiver_carries_the_load():
    c = sg()
    c.step(sample(fy=2.0))
    c.step(sample(fy=1.0))  # the receiver took half of the weight while the object stuck ...
    c.step(sample(fy=1.0))  # ... for two steps (the memory keeps the share one step back)
    c.step(sample(fy=1.0, vx=0.05))  # share 0.5 < s_guard 0.8 before the slide: it is taking it
    assert c.gain[0] == 1.0


def test_releases_when_the_load_is_taken_and_catches_a_falling_object():
    c = sg(release_share=0.3, ease_off=0.3)
    c.step(sample(fy=2.0))
    grip, expected = [], 9.0
    for _ in range(20):
        grip.append(c.step(sample(fy=0.4))[0])  # share 0.2 < s_rel: demand 0
    for g in grip:
        expected = expected * 0.7
        if expected < 0.2:
            expected = 0.0
        assert g == pytest.approx(expected)
    assert grip[-1] == 0.0 and c.mode[0] == 2  # release
    # the object moves sideways with the receiver: no catch
    assert c.step(sample(fy=0.0, vx=0.03, vy=0.02))[0] == 0.0
    # it falls (v_y > 1.5 |v_x|): grip at once with the full hold
    assert c.step(sample(fy=0.0, vx=0.01, vy=0.03))[0] == pytest.approx(9.0)


def test_clamped_to_the_force_limit_and_needs_a_load_to_start():
    c = sg()
    assert c.step(sample(fy=50.0))[0] == 140.0
    c = sg()
    with pytest.raises(GripperError, match="no downward load"):
        c.step(sample(fy=0.0))
    with pytest.raises(GripperError):
        SlipGuardParams(release_share=1.0)
    with pytest.raises(GripperError):
        make_controller("SG", colour=1.0)


def test_vectorised_equals_one_episode_at_a_time():
    rng = np.random.default_rng(3)
    n, steps = 6, 60
    fy = np.abs(rng.normal(2.0, 1.0, (steps, n))) + 0.05
    fx = rng.normal(0.0, 2.0, (steps, n))
    vx = rng.choice([0.0, 0.006, 0.02], (steps, n))
    vy = rng.choice([0.0, 0.006, -0.01, 0.03], (steps, n))
    batch = make_controller("SG")
    batch.reset(n)
    out = np.array([batch.step(sample(fx=fx[k], fy=fy[k], vx=vx[k], vy=vy[k])) for k in range(steps)])
    for i in range(n):
        one = make_controller("SG")
        one.reset(1)
        single = [one.step(sample(fx=fx[k, i], fy=fy[k, i], vx=vx[k, i], vy=vy[k, i]))[0] for k in range(steps)]
        np.testing.assert_allclose(out[:, i], single, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- version 3


def sg3(**kw) -> SlipGuardController:
    c = make_controller("SG", **kw)
    c.reset(1)
    return c


def test_v3_hold_is_weight_scaled_and_capped():
    assert sg3().step(sample(fy=2.0))[0] == pytest.approx(5.5 * 2.0 + 1.0)  # 12 N, below the cap
    assert sg3().step(sample(fy=5.0))[0] == pytest.approx(20.0)  # 5.5 · 5 + 1 = 28.5 N, capped at 20 N
    c = make_controller("SG")
    c.reset(3)  # per episode: 0.1 N → 1.55 N, 3.4 N → 19.7 N, 3.5 N → 20.25 → 20 N
    np.testing.assert_allclose(c.step(sample(fy=np.array([0.1, 3.4, 3.5]))), [1.55, 19.7, 20.0], rtol=0, atol=1e-12)


def test_v3_does_not_grip_harder_on_a_downward_pull():
    # W0 = 2 N (hold 12 N); a downward pull doubles F_sy (share 2): level (2 − 0.5)/0.5 = 3,
    # capped at s_cap = 1 in v3 (demand 12 N) but at 3 in v2 (demand 3 · 9 = 27 N).
    c = sg3()
    c.step(sample(fy=2.0))
    assert c.step(sample(fy=4.0))[0] == pytest.approx(12.0)
    c = sg()
    c.step(sample(fy=2.0))
    assert c.step(sample(fy=4.0))[0] == pytest.approx(27.0)
    # below the hold the share is followed as before: share 0.75 → level 0.5 → 6 N
    c = sg3()
    c.step(sample(fy=2.0))
    assert c.step(sample(fy=1.5))[0] == pytest.approx(6.0)


def test_v3_slip_guard_and_catch_scale_the_capped_hold():
    c = sg3()
    c.step(sample(fy=5.0))  # hold 20 N (capped)
    # |v| = 10 mm/s = 2 v_th: g = 1 + 20 · 0.01 · 2 = 1.4, demand 1.4 · 20 = 28 N (above the cap: the
    # cap limits the rest hold, not what a slide asks for)
    assert c.step(sample(fy=5.0, vx=0.01))[0] == pytest.approx(28.0)
    for _ in range(3):
        c.step(sample(fy=1.0))  # share 0.2 < s_rel: released
    assert c.grip_force_n[0] == 0.0
    # falling (v_y > 1.5 |v_x|): catch with g · F_hold = 28 N
    assert c.step(sample(fy=0.0, vy=0.03))[0] == pytest.approx(28.0)


def test_presets_and_hold_cap_validation():
    assert make_controller("SG").params == SlipGuardParams()
    assert make_controller("SG-v2").params == SlipGuardParams(hold_per_weight=4.0, max_hold_force_n=float("inf"),
                                                              share_cap=3.0)
    assert make_controller("SG-v2", ease_off=0.3).params.ease_off == 0.3
    with pytest.raises(GripperError, match="max_hold_force_n"):
        SlipGuardParams(max_hold_force_n=0.5)  # not above F_min = 1 N
    with pytest.raises(GripperError, match="max_hold_force_n"):
        SlipGuardParams(max_hold_force_n=float("nan"))
    with pytest.raises(GripperError, match="SG-v2: unknown parameter"):
        make_controller("SG-v2", colour=1.0)
