"""Automatic tuning (services/studies/gripper/tuning.py, tune_cma.py, tune_command.py): the search
space, the batched evaluation against separate runs, the objective's numbers, the CMA-ES loop's
files and resume, and the CLI's errors."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from robot_sim.contact.episode import run_vectorised
from services.gripper.controllers.registry import make_controller
from services.studies.cli import main as study_main
from services.studies.gripper.oracle_family import bench_chunks
from services.studies.gripper.tune_cma import run_cma, state_path
from services.studies.gripper.tuning import OBJECTIVE_WEIGHTS, SPACES, Scores, evaluate


@pytest.fixture(scope="module")
def chunks():
    return bench_chunks(1000, 48, 24, "wide")


def test_space_round_trip_and_bounds():
    space = SPACES["SG"]
    start = space.defaults()
    assert start["hold_per_weight"] == 5.5 and start["max_hold_force_n"] == 20.0
    back = space.to_params(space.to_unit(start))
    assert back == pytest.approx(start, rel=1e-9)
    lo = space.to_params(np.full(len(space.names), -3.0))  # clipped to the box
    assert lo["hold_per_weight"] == pytest.approx(2.0) and lo["adapt_rate_per_s"] == pytest.approx(1.0)
    mid = space.to_params(np.full(len(space.names), 0.5))
    assert mid["hold_per_weight"] == pytest.approx(np.sqrt(2.0 * 15.0))  # log scale: geometric mean
    assert mid["release_share"] == pytest.approx(0.5)  # linear


def test_hi_space_keeps_zero_load_grip_below_initial_grip():
    p = SPACES["HI"].to_params([0.0, 0.5, 1.0])  # F_Go 5 N, F_ZLG would be 20 N
    assert p["initial_grip_force_n"] == pytest.approx(5.0)
    assert p["zero_load_grip_force_n"] == pytest.approx(4.5)
    make_controller("HI", **p)  # a valid HI


def _noise_free(chunk):
    sensors = replace(chunk.config.sensors, ft_noise_std_n=0.0, ft_bias_std_n=0.0, accel_noise_std_m_s2=0.0)
    return replace(chunk, config=replace(chunk.config, sensors=sensors))


def test_batched_sets_give_the_same_outcomes_as_separate_runs(chunks):
    """Without sensor noise (drawn per batch position) each set's slice is exactly its own run."""
    sets = [{}, {"hold_per_weight": 9.0, "release_share": 0.3}]
    chunk, noise = _noise_free(chunks[0][0]), chunks[0][1]
    batched = evaluate([(chunk, noise)], "SG", sets)
    for i, params in enumerate(sets):
        alone = run_vectorised(chunk.config, chunk.receivers,
                               make_controller("SG", period_s=chunk.control_period_s, **params), seed=noise)
        np.testing.assert_array_equal(batched.dropped[i], alone.dropped)
        take = chunk.behaviour == 0
        np.testing.assert_allclose(batched.overshoot_n[i][take], alone.force_overshoot_n[take])
    assert not np.array_equal(batched.failed[0], batched.failed[1]) or not np.allclose(
        np.nan_to_num(batched.overshoot_n[0]), np.nan_to_num(batched.overshoot_n[1]))


def test_objective_numbers():
    nan = np.nan
    s = Scores(failed=np.array([[True, False, False, False]]), dropped=np.array([[True, False, False, False]]),
               handed_over=np.array([[False, True, True, False]]),
               overshoot_n=np.array([[2.0, 10.0, 20.0, nan]]), release_time_s=np.array([[nan, 0.4, 0.6, nan]]))
    p95 = np.percentile([2.0, 10.0, 20.0], 95)
    w = OBJECTIVE_WEIGHTS
    expected_under = 0.25 + w["overshoot_p95_per_n"] * p95 + w["release_time_per_s"] * 0.5
    assert s.objective(hi_p95_n=30.0)[0] == pytest.approx(expected_under)
    assert s.objective(hi_p95_n=p95 - 2.0)[0] == pytest.approx(expected_under + w["above_hi_per_n"] * 2.0)
    # A drop weighed 3×: the one drop (a quarter of the episodes) adds two more quarters.
    assert s.objective(hi_p95_n=30.0, drop_weight=3.0)[0] == pytest.approx(expected_under + 2 * 0.25)
    assert s.summary(0, 30.0, drop_weight=3.0)["objective"] == pytest.approx(expected_under + 0.5)
    # A heavier weight above HI's p95: 2 N above at 1 per N adds 2 (as if every episode failed twice).
    assert s.objective(hi_p95_n=p95 - 2.0, above_hi_per_n=1.0)[0] == pytest.approx(expected_under + 2.0)
    assert s.objective(hi_p95_n=30.0, above_hi_per_n=1.0)[0] == pytest.approx(expected_under)  # below HI: no cost
    none = Scores(*(a.copy() for a in (s.failed, s.dropped, np.zeros_like(s.handed_over), s.overshoot_n,
                                       np.full_like(s.release_time_s, nan))))
    assert none.release_time_median_s()[0] == 3.5  # hands nothing over: the episode's length


def test_cma_writes_every_generation_improves_and_resumes(tmp_path, chunks):
    out = tmp_path / "tune.json"
    small = chunks[:1]
    state = run_cma(SPACES["HI"], small, budget=9, out=out, hi_p95_n=15.0, provenance={"t": 1}, popsize=4)
    doc = json.loads(out.read_text())
    assert doc["generations"] == 2 and doc["evaluations"] == 9 and state_path(out).exists()
    assert doc["best"]["objective"] <= doc["start"]["objective"]
    assert [h["evaluations"] for h in doc["history"]] == [5, 9]
    again = run_cma(SPACES["HI"], small, budget=13, out=out, hi_p95_n=15.0, provenance={"t": 1}, resume=True)
    assert again.evaluations == 13 and len(again.history) == 3
    assert again.best["objective"] <= state.best["objective"]
    alone = evaluate(small, "HI", [again.best_params]).summary(0, 15.0)
    assert json.loads(out.read_text())["best_rerun"] == pytest.approx(alone)  # the figures to quote: run alone


def test_cli_resume_without_files_is_a_usage_error(tmp_path, capsys):
    assert study_main(["tune", "--controller", "SG", "--resume", "--out", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err
    assert "--resume needs" in err and err.count("\n") == 1


def test_cli_unknown_controller_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        study_main(["tune", "--controller", "NOPE"])
    assert exc.value.code == 2


def test_cli_tunes_and_writes_a_preset_the_registry_format_reads(tmp_path, capsys):
    presets = tmp_path / "presets.json"
    code = study_main(["tune", "--controller", "HI", "-n", "24", "--chunk-size", "24", "--budget", "5",
                       "--popsize", "4", "--out", str(tmp_path / "hi.json"), "--write-preset", "HI-x",
                       "--presets-file", str(presets), "--quiet", "--workers", "1"])
    assert code == 0
    doc = json.loads(presets.read_text())["HI-x"]
    assert doc["base"] == "HI" and set(doc["params"]) == set(SPACES["HI"].names)
    assert doc["provenance"]["seed"] == 1000 and "best J" in capsys.readouterr().out


def test_cli_drop_weight_below_one_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        study_main(["tune", "--controller", "SG", "--drop-weight", "0.5"])
    assert exc.value.code == 2 and "within 1–100" in capsys.readouterr().err


def test_cli_above_hi_weight_out_of_range_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        study_main(["tune", "--controller", "SG", "--above-hi-weight", "-1"])
    assert exc.value.code == 2 and "within 0–100" in capsys.readouterr().err


def test_cli_above_hi_weight_reaches_the_objective_and_the_provenance(tmp_path):
    presets = tmp_path / "presets.json"
    assert study_main(["tune", "--controller", "HI", "-n", "24", "--chunk-size", "24", "--budget", "5",
                       "--popsize", "4", "--out", str(tmp_path / "hi.json"), "--write-preset", "HI-y",
                       "--presets-file", str(presets), "--above-hi-weight", "2.5", "--quiet", "--workers", "1"]) == 0
    doc = json.loads((tmp_path / "hi.json").read_text())
    assert doc["provenance"]["weights"]["above_hi_per_n"] == 2.5
    best = doc["best_rerun"]
    over = max(best["overshoot_p95_n"] - best["hi_overshoot_p95_n"], 0.0)
    w = OBJECTIVE_WEIGHTS
    expected = (best["failure_rate"] + w["overshoot_p95_per_n"] * best["overshoot_p95_n"]
                + w["release_time_per_s"] * best["release_time_median_s"] + 2.5 * over)
    assert best["objective"] == pytest.approx(expected)


def test_cli_p95_margin_moves_the_hinge_below_his_p95(tmp_path, capsys):
    common = ["tune", "--controller", "HI", "-n", "24", "--chunk-size", "24", "--budget", "5", "--popsize", "4",
              "--quiet", "--workers", "1"]
    assert study_main([*common, "--out", str(tmp_path / "a.json")]) == 0
    assert study_main([*common, "--out", str(tmp_path / "b.json"), "--p95-margin", "2.5"]) == 0
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("a.json", "b.json"))
    assert b["provenance"]["p95_margin_n"] == 2.5
    assert b["start"]["hi_overshoot_p95_n"] == pytest.approx(a["start"]["hi_overshoot_p95_n"] - 2.5)
    assert "HI's p95 − 2.5 N" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        study_main([*common, "--p95-margin", "25"])
    assert exc.value.code == 2
