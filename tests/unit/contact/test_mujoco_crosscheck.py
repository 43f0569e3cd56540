"""The contact plant against MuJoCo (`robot_sim.contact.crosscheck`): a few scenarios where
both plants must agree within the stated tolerances, and cases that show the check fails
when a plant is wrong (a wrong μ, our μ_k < μ_s)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="the `mujoco` wheel is not installed here: the MuJoCo cross-check cannot run")

from robot_sim.contact.config import GRAVITY_M_S2, ObjectParams  # noqa: E402
from robot_sim.contact.crosscheck.catalogue import difference_cases, onset_case, quick_cases, slide_cases  # noqa: E402
from robot_sim.contact.crosscheck.compare import QUANTITIES, Case, compare_case, problems  # noqa: E402
from robot_sim.contact.crosscheck.measure import onset_index  # noqa: E402
from robot_sim.contact.crosscheck.mjcf import MujocoParams, MujocoPinch  # noqa: E402
from robot_sim.contact.crosscheck.runs import run_mujoco  # noqa: E402


def _rows(result) -> dict:
    return {r.quantity: r for r in result.rows}


def test_the_model_is_what_the_docs_say():
    """Elliptic cones, impratio, μ/2 per pad, the pads' footprint equals our pad extents, and
    at rest the pads press with F_G each and carry exactly the weight."""
    obj = ObjectParams()
    pinch = MujocoPinch(obj, 0.6)
    m = pinch.model
    assert m.opt.cone == 1 and m.opt.impratio == pytest.approx(200.0)  # mjCONE_ELLIPTIC
    assert np.allclose(m.pair_friction[:, :2], 0.3) and set(m.pair_dim) == {3}
    assert pinch.footprint_m() == pytest.approx((obj.pad_extent_x_m, obj.pad_extent_y_m))
    pinch.settle(10.0)
    for _ in range(200):
        pinch.step(10.0)
    normal, friction = pinch.pad_forces_n()
    assert normal == pytest.approx(20.0, rel=1e-3)
    assert friction == pytest.approx(obj.weight_n, rel=1e-3)
    _, y, _, vy = pinch.object_state()
    assert abs(vy) < 2e-4 and abs(y) < 1e-4  # stuck: only MuJoCo's slow creep (< 0.2 mm/s)


@pytest.mark.parametrize("case", quick_cases(), ids=lambda c: c.scenario.name)
def test_both_plants_agree_on_the_ci_cases(case):
    res = compare_case(case)
    bad = [f"{r.label}: ours {r.ours}, MuJoCo {r.mujoco} ({r.tolerance})" for r in res.rows if not r.agree]
    assert bad == []
    assert problems([res]) == []


def test_slip_onset_is_coulombs_on_both_plants():
    """Slip starts where |F_p u + W| = μ F_G; the 1 mm/s detector adds ~√(2 M v ṙ) ≈ 0.03–0.07 N."""
    case = onset_case(0.2, 0.6, 30.0, False)
    sc = case.scenario
    res = compare_case(case)
    row = _rows(res)["onset_pull_n"]
    coulomb = sc.onset_pull_n(15.0)
    assert coulomb == pytest.approx(-sc.weight_n * 0.5 + math.sqrt(9.0 ** 2 - (sc.weight_n * math.sqrt(3) / 2) ** 2))
    for value in (row.ours, row.mujoco):
        assert 0.0 < value - coulomb < 0.1
    assert abs(row.mujoco - row.ours) <= 0.02 * row.ours


def test_a_slide_caught_by_a_regrasp_agrees_point_by_point():
    case = next(c for c in slide_cases() if c.scenario.name == "regrasp at 0.48 s")
    rows = _rows(compare_case(case))
    assert rows["caught"].ours is True and rows["caught"].mujoco is True
    assert rows["slide_distance_mm"].ours == pytest.approx(4.8, abs=0.3)
    assert abs(rows["slide_distance_mm"].difference) < 0.2
    assert rows["in_pad_gap_mm"].mujoco < 0.2


def test_a_wrong_mu_in_mujoco_disagrees():
    """The check can fail: MuJoCo given 0.8 μ starts the slide ~20 % earlier than our plant."""
    case = onset_case(0.2, 0.6, 0.0, False)
    right, wrong = compare_case(case), compare_case(replace(case, mujoco_mu=0.48))
    assert _rows(right)["onset_pull_n"].agree
    row = _rows(wrong)["onset_pull_n"]
    assert not row.agree and row.mujoco < 0.85 * row.ours
    assert len(problems([wrong])) == 1 and "disagrees" in problems([wrong])[0]


def test_our_kinetic_friction_below_static_shows_as_a_known_difference():
    """Our default μ_k = 0.5 < μ_s = 0.6 (MuJoCo has one coefficient): same onset, but the
    slide goes faster and leaves the pads earlier in ours; the comparison must show it."""
    case = next(c for c in difference_cases() if c.scenario.name.startswith("2 N along 0°, ours μ_k"))
    res = compare_case(case)
    rows = _rows(res)
    assert rows["onset_time_s"].agree and rows["left"].agree
    assert not rows["leave_time_s"].agree and rows["leave_time_s"].ours < rows["leave_time_s"].mujoco
    assert problems([res]) == []
    same_mu = replace(case, scenario=replace(case.scenario, ours_mu_kinetic=None))
    assert problems([compare_case(same_mu)]) == [f"{case.scenario.name}: expected a disagreement ({case.note}) "
                                                 "but all agree"]


def test_mujoco_contacts_end_where_our_pads_end():
    """Pulled out along x under a 15 N grip: MuJoCo's pad contacts exist until the box passes
    the footprint (our pad extent) and none after, though the pads still press."""
    run = run_mujoco(onset_case(0.2, 0.6, 0.0, True).scenario)
    left = np.flatnonzero(run.left)[0]
    assert run.x_m[left] > 0.04 and np.all(run.grip_force_n > 0)
    assert np.all(run.contacts[:left] > 0) and np.all(run.contacts[left + 1:] == 0)
    assert onset_index(run) < left


def test_gravity_alone_at_the_edge_of_the_cone():
    """μ F_G = 1.03 W holds on both plants; 0.97 W slides out and drops on both."""
    from robot_sim.contact.crosscheck.catalogue import receiver_cases

    hold, slide = (c for c in receiver_cases() if c.scenario.name.startswith("no receiver"))
    held, fell = _rows(compare_case(hold)), _rows(compare_case(slide))
    assert held["dropped"].ours is False and held["dropped"].mujoco is False
    assert fell["dropped"].ours is True and fell["dropped"].mujoco is True and fell["drop_time_s"].agree
    # 0.97 W: a = 0.03 g until it leaves 3 cm down, then free fall to 10 cm.
    t_leave = math.sqrt(2 * 0.03 / (0.03 * GRAVITY_M_S2))
    assert fell["drop_time_s"].ours == pytest.approx(t_leave + 0.10, abs=0.02)


def test_tolerances_are_stated_for_every_measured_quantity():
    assert set(QUANTITIES) >= {"onset_pull_n", "leave_time_s", "slide_distance_mm", "caught", "dropped"}
    assert QUANTITIES["onset_pull_n"][2].rel == 0.02
    assert Case(onset_case(0.1, 1.0, 60.0, True).scenario, "g").mujoco == MujocoParams()


def test_the_mujoco_settings_are_the_ones_that_make_a_clean_coulomb_contact():
    """Why impratio 200 and the soft solimp (docs): a stuck box near the cone creeps < 0.1 mm/s
    (17 mm/s with MuJoCo's impratio 1), and a sliding box keeps its pads in contact with the
    mean friction at μ F_G (MuJoCo's default solimp makes the pads chatter)."""
    from robot_sim.contact.crosscheck.diagnostics import creep, slide_contact
    from robot_sim.contact.crosscheck.mjcf import MUJOCO_DEFAULT_SOLIMP

    assert creep(cone_fraction=0.95)[0] < 1e-4
    assert creep(MujocoParams(impratio=1.0), cone_fraction=0.95)[0] > 1e-2
    clean, chatter = slide_contact(), slide_contact(MujocoParams(solimp=MUJOCO_DEFAULT_SOLIMP))
    assert clean.lost_share == 0.0 and clean.normal_spread < 0.01 and clean.friction_ratio == pytest.approx(1, abs=0.01)
    assert chatter.lost_share > 0.05 and chatter.normal_spread > 0.2
    assert chatter.friction_ratio == pytest.approx(1, abs=0.03)  # the mean is still Coulomb's
