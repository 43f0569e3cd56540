"""Drop attribution: the references, the classes, and the actuator limit the bridge test relies on."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from robot_sim.contact.config import GripperParams, SimConfig
from robot_sim.contact.episode import run_episode, run_vectorised
from robot_sim.contact.outcome import BatchOutcome
from robot_sim.contact.receiver import behaviour_by_name
from services.studies.gripper.attribution import (
    AttributedOutcome,
    DropClass,
    MaxHoldReference,
    ReactiveMaxHold,
    classify_drops,
    paired_difference_ci,
    paired_overshoot,
    run_attributed,
)
from services.gripper.controllers.registry import make_controller
from services.studies.gripper.episodes import EpisodeDistribution, sample_chunk
from tests.unit.gripper.helpers import sample


def _batch(**cols) -> BatchOutcome:
    n = len(next(iter(cols.values())))
    base = {f.name: np.zeros(n) for f in fields(BatchOutcome)}
    for name in ("released", "dropped", "handed_over"):
        base[name] = np.zeros(n, dtype=bool)
    base.update({k: np.asarray(v) for k, v in cols.items()})
    return BatchOutcome(**base)


def test_classes_by_hand():
    # 0 kept; 1 the reference drops too; 2 released into a holding hand that let go later;
    # 3 released while the receiver did not hold it; 4 slid out of a closed gripper.
    out = _batch(dropped=[False, True, True, True, True], released=[True, True, True, True, False],
                 release_time_s=[1.0, 1.0, 1.0, 1.0, np.nan], drop_time_s=[np.nan, 1.5, 2.0, 1.2, 0.8])
    att = AttributedOutcome(outcome=out, holds_at_release=np.array([True, False, True, False, False]))
    ref = np.array([False, True, False, False, False])
    assert classify_drops(att, ref).tolist() == [DropClass.NONE, DropClass.UNAVOIDABLE, DropClass.RECEIVER_LET_GO,
                                                 DropClass.CONTROLLER, DropClass.CONTROLLER]
    with pytest.raises(ValueError):
        classify_drops(att, ref[:3])


def test_paired_overshoot_uses_only_episodes_both_handed_over():
    a = _batch(handed_over=[True, True, False, True], force_overshoot_n=[4.0, 6.0, 1.0, 30.0])
    b = _batch(handed_over=[True, True, True, False], force_overshoot_n=[5.0, 9.0, 2.0, 1.0])
    p = paired_overshoot(a, b, taking=np.array([True, True, True, True]))
    assert p["episodes"] == 2
    assert p["a_median_n"] == 5.0 and p["b_median_n"] == 7.0
    assert p["median_difference_n"] == pytest.approx(-2.0)  # median of (−1, −3)


def test_reactive_reference_grips_hard_at_the_first_change():
    c = ReactiveMaxHold()
    c.reset(2)
    assert c.step(sample(fy=[2.0, 1.0])).tolist() == [9.0, 5.0]  # 4 W + 1 N at rest
    assert c.step(sample(fx=[0.6, 0.2], fy=[2.0, 1.0])).tolist() == [140.0, 5.0]  # |ΔF| 0.6 > 0.5 N
    assert c.step(sample(fy=[2.0, 1.0], vy=[0.0, 0.006])).tolist() == [140.0, 140.0]  # slip > 5 mm/s
    m = MaxHoldReference()
    m.reset(3)
    assert m.step(sample(fy=[1.0, 2.0, 3.0])).tolist() == [140.0] * 3


def test_run_attributed_matches_run_vectorised():
    chunk = sample_chunk(EpisodeDistribution(), 12, np.random.default_rng(5))
    a = run_attributed(chunk.config, chunk.receivers, make_controller("SG"), seed=9)
    b = run_vectorised(chunk.config, chunk.receivers, make_controller("SG"), seed=9)
    for f in fields(BatchOutcome):
        np.testing.assert_array_equal(getattr(a.outcome, f.name), getattr(b, f.name), err_msg=f.name)
    assert not np.any(a.holds_at_release & ~a.outcome.released)


def _dropped(controller, strength_n: float, speed_m_s: float) -> bool:
    cfg = SimConfig(gripper=GripperParams(speed_limit_m_s=speed_m_s), duration_s=4.5)
    rec = behaviour_by_name("dropping", weight_n=0.2 * 9.81, reach_start_s=0.8, grasp_strength_n=strength_n)
    return run_episode(cfg, rec, controller, seed=3).outcome.dropped


def test_no_sensor_driven_law_holds_the_default_dropping_receiver_at_50_n_per_s():
    # Default dropping receiver (20 N hook-and-pull, φ = 0, 0.2 kg, μ_s 0.6), the bridge's seed 3.
    assert not _dropped(MaxHoldReference(), 20.0, 0.1)  # 140 N from the start holds it ...
    assert _dropped(ReactiveMaxHold(), 20.0, 0.1)  # ... reacting at the first 0.5 N does not
    assert not _dropped(ReactiveMaxHold(), 10.0, 0.1)
    assert _dropped(ReactiveMaxHold(), 12.0, 0.1)
    assert not _dropped(ReactiveMaxHold(), 20.0, 0.3)  # 150 N/s would be enough
    assert not _dropped(make_controller("SG"), 6.0, 0.1)  # the bridge test's receiver
    assert _dropped(make_controller("SG"), 8.0, 0.1)
    assert not _dropped(make_controller("SG"), 15.0, 0.3)


def test_paired_difference_ci_constant_shift_is_exact():
    b = np.linspace(1.0, 20.0, 200)
    assert paired_difference_ci(b + 1.0, b, 95.0) == pytest.approx((1.0, 1.0, 1.0))


def test_paired_difference_ci_finds_no_difference_between_identically_distributed_samples():
    rng = np.random.default_rng(3)
    a, b = rng.exponential(5.0, 3000), rng.exponential(5.0, 3000)
    d, lo, hi = paired_difference_ci(a, b, 95.0)
    assert lo <= 0.0 <= hi and lo <= d <= hi
    assert hi - lo < 3.0


def test_paired_difference_ci_covers_the_true_p95_difference_and_agrees_with_a_plain_bootstrap():
    rng = np.random.default_rng(4)
    b = rng.exponential(5.0, 4000)
    a = 1.5 * b  # p95 of exp(scale 5) = 5 ln 20 = 14.98 N; 1.5 x → difference 7.49 N
    d, lo, hi = paired_difference_ci(a, b, 95.0)
    assert lo > 0.0 and lo <= 0.5 * 5 * np.log(20) <= hi
    # Independent check: percentile bootstrap by hand, same pairs resampled.
    idx = np.random.default_rng(5).integers(0, b.size, size=(2000, b.size))
    diffs = np.percentile(a[idx], 95, axis=1) - np.percentile(b[idx], 95, axis=1)
    plain_lo, plain_hi = np.percentile(diffs, [2.5, 97.5])
    assert abs(lo - plain_lo) < 0.3 and abs(hi - plain_hi) < 0.3
    with pytest.raises(ValueError):
        paired_difference_ci(a, b[:10], 95.0)
