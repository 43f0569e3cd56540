"""The oracle's report next to the benchmark (services/studies/gripper/oracle_report.py): rates,
gaps and intervals on hand-made outcomes, the redrawn episodes, and the bench CLI's default."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from robot_sim.contact.outcome import BatchOutcome
from services.gripper.errors import GripperError
from services.studies.cli import main as study_main
from services.studies.gripper import benchmark as B
from services.studies.gripper.oracle import ClairvoyantResult
from services.studies.gripper.oracle_report import (
    OracleResult,
    bound_rows,
    bounds_table,
    failed,
    gap_rows,
    gaps_table,
    mean_difference_ci,
    overshoot_rows,
    run_oracle,
)


def _batch(**cols) -> BatchOutcome:
    n = len(next(iter(cols.values())))
    base = {f.name: np.zeros(n) for f in fields(BatchOutcome)}
    for name in ("released", "dropped", "handed_over"):
        base[name] = np.zeros(n, dtype=bool)
    base.update({k: np.asarray(v) for k, v in cols.items()})
    return BatchOutcome(**base)


def _clairvoyant(success, dropped) -> ClairvoyantResult:
    n = len(success)
    return ClairvoyantResult(success=np.array(success), dropped=np.array(dropped), handed_over=np.zeros(n, bool),
                             overshoot_n=np.zeros(n), release_latch=np.full(n, -1), source=np.zeros(n, np.int8),
                             max_hold_dropped=np.array(dropped), searched=np.zeros(n, bool),
                             release_window=np.zeros(n, np.int64))


# behaviours: taking, taking, dropping, bumping, hesitating, dropping
BEHAVIOUR = np.array([0, 0, 1, 2, 3, 1])


def _case():
    ctrl = _batch(dropped=[False, True, True, False, False, True],
                  handed_over=[True, False, False, False, False, False])
    result = B.BenchResult(outcomes={"X": ctrl, "max-hold": _batch(dropped=[False] * 6)}, mass_kg=np.zeros(6),
                           mu_static=np.zeros(6), pull_angle_rad=np.zeros(6), behaviour=BEHAVIOUR,
                           grasp_start_s=np.zeros(6), seed=1, wall_time_s=0.0)
    oracle = OracleResult(
        clairvoyant=_clairvoyant(success=[True, True, True, True, True, False],
                                 dropped=[False, False, False, False, False, True]),
        family=_batch(dropped=[False, False, True, True, False, True], handed_over=[False] * 6),
        family_capped=_batch(dropped=[True] * 6, handed_over=[False] * 6),
        family_class=_batch(dropped=[False, False, False, False, False, True], handed_over=[True, True] + [False] * 4),
        behaviour=BEHAVIOUR, wall_time_s=0.0)
    return result, oracle


def test_failure_is_a_drop_or_a_taker_not_handed_over():
    out = _batch(dropped=[False, False, True, False], handed_over=[True, False, False, False])
    assert failed(out, np.array([0, 0, 1, 1])).tolist() == [False, True, True, False]


def test_mean_difference_interval():
    assert mean_difference_ci(np.zeros(30)) == (0.0, 0.0, 0.0)
    d = np.r_[np.ones(40), np.zeros(60)]
    m, lo, hi = mean_difference_ci(d)
    assert m == pytest.approx(0.4) and lo < 0.4 < hi and hi - lo == pytest.approx(0.19, abs=0.03)  # ≈ 2 · 1.96 σ
    assert np.isnan(mean_difference_ci(np.array([]))[0])


def test_bound_rows_by_hand():
    _, oracle = _case()
    rows = {r["group"]: r for r in bound_rows(oracle)}
    assert rows["all"]["episodes"] == 6 and rows["all"]["unavoidable"]["rate"] == pytest.approx(1 / 6)
    assert rows["dropping"]["unavoidable"]["rate"] == 0.5 and rows["dropping"]["clairvoyant_fail"]["rate"] == 0.5
    assert rows["taking"]["family_fail"]["rate"] == 1.0  # kept but never handed over
    assert rows["taking"]["family_class_fail"]["rate"] == 0.0 and rows["bumping"]["family_fail"]["rate"] == 1.0
    assert rows["all"]["family_capped_drop"]["rate"] == 1.0
    lo, hi = rows["all"]["unavoidable"]["ci"]
    assert lo < 1 / 6 < hi
    assert "| dropping | 2 | 50.0 [" in bounds_table(list(rows.values()))


def test_gap_rows_by_hand():
    result, oracle = _case()
    rows = {(r["controller"], r["group"]): r for r in gap_rows(result, oracle)}
    assert {c for c, _ in rows} == {"X"}  # the references are not controllers
    r = rows[("X", "all")]
    assert r["fail"]["rate"] == pytest.approx(3 / 6) and r["drop"]["rate"] == pytest.approx(3 / 6)
    assert r["gap_clairvoyant"][0] == pytest.approx((3 - 1) / 6)  # X fails 1, 2, 5; the bound fails 5
    assert r["gap_family"][0] == pytest.approx((3 - 5) / 6)  # the global family fails 0, 1, 2, 3, 5
    assert r["gap_family_class"][0] == pytest.approx((3 - 1) / 6)
    assert r["gap_family_capped"][0] == pytest.approx((3 - 6) / 6)
    assert r["beats_clairvoyant"] == 0
    t = rows[("X", "taking")]
    assert t["gap_clairvoyant"] == pytest.approx((0.5, 0.0, 1.0), abs=0.51)
    assert "| X | taking |" in gaps_table(list(rows.values()))


def test_run_oracle_matches_the_benchmark_episodes_and_refuses_others():
    result = B.run_benchmark(["SG"], 6, seed=2, workers=1, chunk_size=3, progress=False)
    oracle = run_oracle(result, 6, chunk_size=3, search=4)
    np.testing.assert_array_equal(oracle.behaviour, result.behaviour)
    sg_ok = ~failed(result.outcomes["SG"], result.behaviour)
    assert not np.any(sg_ok & ~oracle.clairvoyant.success)
    result.mass_kg = result.mass_kg[::-1].copy()
    with pytest.raises(GripperError, match="differ"):
        run_oracle(result, 6, chunk_size=3, search=0)


def test_bench_reports_the_oracle_by_default(tmp_path):
    common = ["bench", "--controllers", "HI", "-n", "4", "--chunk-size", "4", "--workers", "1", "--no-plots",
              "--no-progress", "--oracle-search", "4"]
    assert study_main([*common, "--out", str(tmp_path / "on")]) == 0
    text = (tmp_path / "on" / "oracle.md").read_text()
    assert "| HI | all |" in text and "unavoidable drops %" in text
    assert (tmp_path / "on" / "oracle_gaps.csv").read_text().startswith("controller,group,episodes,drop,")
    assert (tmp_path / "on" / "oracle_bounds.csv").read_text().startswith("group,episodes,unavoidable,")
    assert study_main([*common, "--no-oracle", "--out", str(tmp_path / "off")]) == 0
    assert not (tmp_path / "off" / "oracle.md").exists()


def test_overshoot_rows_count_the_taking_episodes_handed_over():
    result, oracle = _case()
    result.outcomes["X"] = _batch(dropped=[False] * 6, handed_over=[True, True, False, False, False, True],
                                  force_overshoot_n=[4.0, 8.0, 0.0, 0.0, 0.0, 99.0])
    rows = {r["who"]: r for r in overshoot_rows(result, oracle)}
    assert set(rows) == {"clairvoyant", "family, global", "family, global, p95 ≤ HI", "family, per class", "X"}
    assert rows["X"]["handed_over"] == 2 and rows["X"]["taking"] == 2  # the non-taking episode 5 does not count
    assert rows["X"]["median_n"] == 6.0 and rows["X"]["p95_n"] == pytest.approx(7.8)
    assert rows["X"]["p95_all_taking_n"] == pytest.approx(7.8)  # the two taking episodes are both handed over
    assert rows["family, global"]["p95_all_taking_n"] == 0.0
    assert rows["family, global"]["handed_over"] == 0 and np.isnan(rows["family, global"]["median_n"])
