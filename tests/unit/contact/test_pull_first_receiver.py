"""The taking receivers who pull before they lift (pull-first) or never lift (drag), and the
seeded draws of the receivers (the first batches' draws unchanged)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_sim.contact.config import ContactSimError
from robot_sim.contact.controllers import ConstantGrip, ReleaseAfter
from robot_sim.contact.episode import run_episode
from robot_sim.contact.receiver import (
    Behaviour,
    LiftOrder,
    behaviour_by_name,
    drag,
    dropping,
    lift_order,
    pull_first,
    reference,
    sample_behaviours,
    stack_receivers,
    taking,
)
from robot_sim.contact.rest import reference_settled
from robot_sim.contact.sampling import KINDS

from tests.unit.contact.helpers import quiet_config

CFG = quiet_config(duration_s=3.0)
W = CFG.obj.weight_n


def _pull_and_support(receiver):
    """Hand force on the object, held stuck by a 40 N grip (μ_s 40 N = 24 N > any pull here):
    the pull along u = (cos φ, sin φ) and the upward support beyond the pull's own vertical
    part, both N, over time (s)."""
    tr = run_episode(CFG, receiver, ConstantGrip(40.0), seed=0).trace
    assert np.all(tr.mode == 0)  # stuck all along: the forces are the receiver's, not a slide's
    ux, uy = math.cos(receiver.pull_angle_rad), math.sin(receiver.pull_angle_rad)
    along = tr.pull_force_x_n / ux
    support = -(tr.pull_force_y_n - along * uy)
    return tr.time_s, along, support


def _first(t, cond):
    hits = np.flatnonzero(cond)
    return t[hits[0]] if hits.size else math.inf


@pytest.mark.parametrize("phi_rad", [-0.3, 0.0, 0.3])
def test_pull_first_pulls_before_it_lifts_and_the_lift_first_taker_the_other_way(phi_rad):
    # 3 cm of pull: about 10 N through the hand's 400 N/m, below the 20 N grasp cap.
    pf = pull_first(pull_angle_rad=phi_rad, pull_distance_m=0.03, lift_delay_s=0.5)
    t, along, support = _pull_and_support(pf)
    t_pull, t_lift = _first(t, along > 2.0), _first(t, support > 0.5 * W)
    assert t_pull < pf.lift_start_s <= t_lift  # the pull is there before the lift begins
    assert t_lift - t_pull > 0.3
    assert support[np.flatnonzero(along > 2.0)[0]] < 0.05 * W  # nothing carried when the pull is felt
    assert support.max() > 0.7 * W and along.max() > 9.0  # and it does lift later, and pull hard
    t, along, support = _pull_and_support(taking(pull_angle_rad=phi_rad, pull_distance_m=0.03))
    assert support[np.flatnonzero(along > 2.0)[0]] > 0.5 * W  # the lift-first taker carries first


@pytest.mark.parametrize("phi_rad", [-0.3, 0.0, 0.3])
def test_drag_pulls_and_never_lifts(phi_rad):
    t, along, support = _pull_and_support(drag(pull_angle_rad=phi_rad, pull_distance_m=0.03))
    assert along.max() > 9.0
    assert np.all(support < 0.05 * W)


def test_a_drag_still_takes_the_object_where_a_dropping_receiver_drops_it():
    for phi in (0.0, 0.3):
        taken = run_episode(CFG, drag(pull_angle_rad=phi), ReleaseAfter(40.0, 1.3), seed=0).outcome
        assert taken.released and taken.handed_over and not taken.dropped
        lost = run_episode(CFG, dropping(pull_angle_rad=phi), ReleaseAfter(40.0, 1.3), seed=0).outcome
        assert lost.released and lost.dropped


def test_weight_feedforward_follows_the_lift_window():
    t = np.linspace(0.0, 3.0, 3001)
    pf, tk, dr = pull_first(lift_delay_s=0.5, lift_duration_s=0.4), taking(), drag()
    ff_pf, ff_tk, ff_dr = reference(t, pf)[5], reference(t, tk)[5], reference(t, dr)[5]
    grasp = reference(t, pf)[4]
    assert np.all(ff_pf[t <= pf.lift_start_s] == 0.0) and np.any(grasp[t <= pf.lift_start_s] > 0.9)
    done = t >= pf.lift_start_s + pf.lift_duration_s
    np.testing.assert_allclose(ff_pf[done], -pf.weight_feedforward * grasp[done] * pf.weight_estimate_n)
    np.testing.assert_array_equal(ff_tk, -tk.weight_feedforward * reference(t, tk)[4] * tk.weight_estimate_n)
    assert np.all(ff_dr == 0.0)
    assert pf.behaviour == dr.behaviour == Behaviour.TAKING
    assert [lift_order(p) for p in (tk, pf, dr)] == [LiftOrder.LIFT_FIRST, LiftOrder.PULL_FIRST, LiftOrder.NEVER_LIFTS]
    np.testing.assert_array_equal(lift_order(stack_receivers([dr, tk, pf])), [2, 0, 1])
    assert not reference_settled(pf, pf.lift_start_s + 0.1) and reference_settled(pf, 5.0)
    assert behaviour_by_name("drag").lift_start_s == math.inf
    with pytest.raises(ContactSimError):
        pull_first(lift_delay_s=-0.1)
    with pytest.raises(ContactSimError):
        pull_first(lift_duration_s=0.0)


def test_mixed_draws_are_those_of_the_first_batches_and_mixed_wide_has_every_kind():
    # Pinned from the receiver model before the pull-first kinds existed (same seed, same draws).
    b = sample_behaviours("mixed", 8, np.random.default_rng(4), weight_n=2.0)
    assert [int(x.behaviour) for x in b] == [2, 3, 1, 2, 0, 3, 0, 1]
    assert [x.pull_angle_rad for x in b][:3] == [3.457742858248628, 0.4211986465329273, 0.4637029284449079]
    assert b[4].pull_start_s == 1.017499550085248 and b[7].pull_start_s == 1.179670651151236
    assert all(x.lift_start_s == -1.0 for x in b)
    wide = stack_receivers(sample_behaviours("mixed-wide", 300, np.random.default_rng(1)))
    order = lift_order(wide)
    taking_ = wide.behaviour == Behaviour.TAKING
    assert set(np.unique(wide.behaviour)) == {0, 1, 2, 3}
    assert {int(o) for o in order[taking_]} == {0, 1, 2}
    assert 0.4 < np.mean(taking_) < 0.6  # three of six kinds take
    pf = [p for p in sample_behaviours("pull-first", 50, np.random.default_rng(2))]
    delays = np.array([p.lift_start_s - p.pull_start_s for p in pf])
    assert delays.min() >= 0.3 and delays.max() <= 0.8
    assert set(KINDS) == {"taking", "dropping", "bumping", "hesitating", "pull-first", "drag"}
    with pytest.raises(ContactSimError):
        sample_behaviours("juggling", 1, np.random.default_rng(0))
