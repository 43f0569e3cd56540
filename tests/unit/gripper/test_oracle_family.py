"""The sensor-only family of the oracle bound (services/studies/gripper/oracle_family.py): the law
step by step, its parameter box, the benchmark's episodes, the tuning and the stored result."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from robot_sim.contact.episode import run_vectorised
from services.gripper.errors import GripperError
from services.studies.gripper import benchmark as B
from services.studies.gripper.episodes import BEHAVIOUR_NAMES
from services.studies.gripper.oracle_family import (
    BOUNDS,
    PARAMS_PATH,
    FamilyParams,
    ShareReleaseLaw,
    TunedFamily,
    bench_chunk,
    bench_chunks,
    evaluate,
    tune,
)
from tests.unit.gripper.helpers import sample


def test_law_holds_by_weight_follows_the_load_and_releases_after_tau():
    law = ShareReleaseLaw(hold_per_weight=[4.0, 4.0], follow_gain=[2.0, 0.0], release_share=0.3, confirm_s=0.03)
    law.reset(2)
    np.testing.assert_allclose(law.step(sample(0.0, fy=2.0, n=2)), [8.0, 8.0])  # c_hold · W0, W0 = 2 N
    np.testing.assert_allclose(law.step(sample(0.01, fx=3.0, fy=4.0, n=2)), [10.0, 8.0])  # k · |F| = 2 · 5 N
    np.testing.assert_allclose(law.step(sample(0.02, fx=100.0, fy=2.0, n=2)), [140.0, 8.0])  # clipped to 140 N
    for k in range(2):  # unloaded (F_sy ≤ 0.3 · 2 N) for 0.02 s < τ: still held
        np.testing.assert_allclose(law.step(sample(0.03 + 0.01 * k, fy=0.5, n=2)), [8.0, 8.0])
    law.step(sample(0.05, fy=2.0, n=2))  # a reload resets the count (a bump, not a taker)
    out = [law.step(sample(0.06 + 0.01 * k, fy=0.5, n=2)) for k in range(3)]
    np.testing.assert_allclose(out[1], [8.0, 8.0])
    np.testing.assert_allclose(out[2], [0.0, 0.0])  # unloaded for τ = 0.03 s: released
    np.testing.assert_allclose(law.step(sample(0.09, fy=2.0, n=2)), [0.0, 0.0])  # and the release is latched


def test_parameters_live_in_their_box():
    p = FamilyParams(5.0, 1.0, 0.4, 0.1)
    assert FamilyParams.from_array(p.as_array()) == p
    assert FamilyParams.from_array([999.0, -1.0, 0.4, 0.1]).hold_per_weight == BOUNDS["hold_per_weight"][1]
    np.testing.assert_allclose(FamilyParams.from_search(p.search_point()).as_array(), p.as_array(), rtol=1e-12)
    np.testing.assert_allclose(p.search_point(), [np.log(5.0), 1.0, 0.4, np.log(0.1)])
    # the box holds the max-hold: 140 N for the lightest benchmark object (0.05 kg), never released
    assert BOUNDS["hold_per_weight"][1] * 0.05 * 9.81 >= 140.0 and BOUNDS["confirm_s"][1] >= 3.5
    with pytest.raises(GripperError):
        FamilyParams(5.0, 1.0, 1.5, 0.1)


def test_bench_chunk_draws_the_benchmarks_episodes_and_noise():
    result = B.run_benchmark(["HI"], 10, seed=4, workers=1, chunk_size=4, progress=False)
    chunks = bench_chunks(4, 10, 4)  # the bench's default population: chunks of one gripper class each
    assert len(chunks) >= 3 and len({c.config.gripper.loop_rate_hz for c, _ in chunks}) > 1
    np.testing.assert_array_equal(np.concatenate([c.mass_kg for c, _ in chunks]), result.mass_kg)
    np.testing.assert_array_equal(np.concatenate([c.behaviour for c, _ in chunks]), result.behaviour)
    assert bench_chunk(4, 10, 4, 1)[0].mass_kg.tolist() == chunks[1][0].mass_kg.tolist()
    from services.gripper.controllers.registry import make_controller

    again = [run_vectorised(c.config, c.receivers, make_controller("HI", period_s=c.control_period_s), seed=s)
             for c, s in chunks]
    np.testing.assert_array_equal(np.concatenate([o.force_overshoot_n for o in again]),
                                  result.outcomes["HI"].force_overshoot_n)  # same sensor noise too


def test_evaluate_runs_members_side_by_side_and_scores_them():
    chunks = [bench_chunk(2, 12, 12, 0, "narrow")]
    members = np.array([[6.0, 0.0, 0.3, 0.2], [15.0, 5.0, 0.05, 0.5], [1.0, 0.0, 0.3, 0.2]])
    s = evaluate(chunks, members)
    assert s.failed.shape == (3, 12) and s.dropped.shape == (3, 12)
    assert np.all(s.failed >= s.dropped)  # every drop is a failure
    take = chunks[0][0].behaviour == 0
    assert np.all(np.isnan(s.overshoot_n[:, ~take])) and np.all(np.isfinite(s.overshoot_n[:, take]))
    assert not np.any(s.handed_over[:, ~take])
    j = s.objective()
    mean_over = [np.mean(row[h]) if h.any() else 0.0 for row, h in zip(s.overshoot_n, s.handed_over)]
    np.testing.assert_allclose(j, s.failed.mean(axis=1) + 1e-4 * np.array(mean_over))
    p95 = s.overshoot_p95_n()
    np.testing.assert_allclose(p95, np.percentile(s.overshoot_n[:, take], 95, axis=1))
    cap = float(p95[0]) + 0.5
    np.testing.assert_allclose(s.objective(cap), j + 0.05 * np.maximum(p95 - cap, 0.0))
    assert s.objective(cap)[0] == j[0] and s.objective(cap)[1] > j[1]  # only the member above the cap pays
    assert s.dropped[2].all()  # a hold of W0 with μ_s < 1 lets every object slide out at rest
    both = s.handed_over[0] & s.handed_over[1]
    assert both.any() and np.all(s.overshoot_n[1, both] > s.overshoot_n[0, both])  # the hard grip pulls harder
    only = evaluate(chunks, members, behaviour=0)
    assert only.failed.shape == (3, int(take.sum()))


def test_tune_returns_a_member_in_the_box_and_is_repeatable():
    chunks = [bench_chunk(5, 8, 8, 0, "narrow")]
    a, sa = tune(chunks, popsize=2, maxiter=1)
    b, _ = tune(chunks, popsize=2, maxiter=1)
    assert a == b
    assert sa["evaluations"] == 16 and sa["episodes"] == 8 and 0.0 <= sa["failure_rate"] <= 1.0
    c, sc = tune(chunks, popsize=2, maxiter=1, overshoot_cap_n=0.0)  # a cap nobody meets: it pays for overshoot
    assert sc["overshoot_cap_n"] == 0.0 and sc["objective"] >= 0.05 * 0.5 * sc["overshoot_p95_n"]
    for name, (lo, hi) in BOUNDS.items():
        assert lo <= getattr(a, name) <= hi


def test_tuned_parameters_round_trip_and_the_shipped_file_is_complete(tmp_path):
    p = FamilyParams(5.0, 1.0, 0.4, 0.1)
    tuned = TunedFamily(p, FamilyParams(3.0, 0.0, 0.5, 0.2), {name: p for name in BEHAVIOUR_NAMES.values()},
                        {"seed": 1000})
    loaded = TunedFamily.load(tuned.save(tmp_path / "p.json"))
    assert loaded == tuned
    np.testing.assert_allclose(loaded.class_members(np.array([0, 2])), [p.as_array(), p.as_array()])
    as_json = str(asdict(p)).replace("'", '"')
    (tmp_path / "bad.json").write_text('{"global": %s, "global_capped": %s, "per_class": {}}' % (as_json, as_json))
    with pytest.raises(GripperError, match="no tuned parameters"):
        TunedFamily.load(tmp_path / "bad.json")
    shipped = TunedFamily.load(PARAMS_PATH)  # what the benchmark reads: tuned on the tuning seed only
    assert shipped.provenance["seed"] == B.TUNING_SEED
    assert shipped.provenance["tuning"]["global_capped"]["overshoot_cap_n"] > 0
