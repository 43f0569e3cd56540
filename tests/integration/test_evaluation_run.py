"""A CI-sized evaluation through the real CLI: 6 episodes, each a whole stack, two at a time on
the engine's local Dask cluster. The report's figures are checked against the per-episode
records (recomputed here with numpy and scipy), every failing episode has its replay command,
each record's outcome is the one its recording holds, and a resume runs only what is missing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from services.recorder.readback import read_component

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[2]
EPISODES, SEED = 6, 11


def _eval(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "services.studies.evaluation.cli", *args], capture_output=True,
                          text=True, env=env, timeout=900)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval") / "run"
    done = _eval("run", "--episodes", str(EPISODES), "--seed", str(SEED), "--workers", "2", "--out", str(out),
                 "--no-progress")
    assert done.returncode == 0, done.stderr[-3000:]
    return out, done


def _records(out: Path) -> list[dict]:
    return [json.loads((out / "episodes" / f"e{k:04d}" / "record.json").read_text()) for k in range(EPISODES)]


def test_the_reports_figures_are_the_records(run):
    out, done = run
    records = _records(out)
    summary = json.loads((out / "report" / "summary.json").read_text())
    n = len(records)
    successes = sum(r["outcome"] == "released" and r["final_holder"] == "receiver" and not r["dropped"]
                    for r in records)
    ci = stats.binomtest(successes, n).proportion_ci(method="wilson")
    assert (summary["success"]["k"], summary["success"]["n"]) == (successes, n)
    assert summary["success"]["low"] == pytest.approx(ci.low) and summary["success"]["high"] == pytest.approx(ci.high)
    assert summary["dropped"]["k"] == sum(r["dropped"] for r in records)
    assert summary["false_stop"]["k"] == sum(bool(r["protective_stops"]) for r in records)
    times = [r["time_to_handover_s"] for r in records if r["success"]]
    median = summary["quantities"]["time_to_handover_s"]["median"]
    assert median["n"] == len(times)
    if times:
        assert median["value"] == pytest.approx(float(np.median(times)))
    behaviours = {r["behaviour"] for r in records}
    assert set(summary["by_behaviour"]) == behaviours
    for b in behaviours:
        group = [r for r in records if r["behaviour"] == b]
        assert summary["by_behaviour"][b]["success"]["n"] == len(group)
    expected_failing = [r["episode"] for r in records if not (
        r["success"] if r["behaviour"] == "taking" else (not r["dropped"] and not r["protective_stops"]))]
    assert summary["failing"] == expected_failing
    report = (out / "report" / "report.md").read_text()
    for k in expected_failing:
        assert f"handover-eval replay --run {out} --episode {k}`" in report
    assert (out / "report" / "outcomes.png").stat().st_size > 10_000
    assert f"{EPISODES} episodes: success" in done.stdout


def test_each_record_is_what_its_recording_says(run):
    out, _done = run
    for r in _records(out):
        assert r["outcome"] != "stack_error", r["reason"]
        recording = Path(r["recording"])
        outcomes = [v[0] for _t, v in read_component(recording, "/bus/supervisor/episode", "EpisodeSummary:outcome")]
        assert outcomes[:1] == [r["outcome"]]
        dropped = any(v[0] for _t, v in read_component(recording, "/bus/sim/truth", "SimTruth:dropped"))
        assert dropped == r["dropped"]
        assert r["draw"]["sim_seed"] == r["seed"]
        profile = (out / "episodes" / f"e{r['episode']:04d}" / "profile.toml").read_text()
        assert f"seed = {r['seed']}" in profile


def test_a_resume_runs_only_the_missing_episode(run):
    out, _done = run
    missing = out / "episodes" / "e0002" / "record.json"
    kept = {k: (out / "episodes" / f"e{k:04d}" / "record.json").stat().st_mtime_ns for k in (0, 1, 3, 4, 5)}
    missing.unlink()
    for checkpoint in out.glob("engine-checkpoint-*"):
        checkpoint.unlink()  # as if the run had been killed before the engine noted the episode
    done = _eval("run", "--resume", "--out", str(out), "--workers", "1", "--no-progress")
    assert done.returncode == 0, done.stderr[-3000:]
    assert missing.exists()
    assert {k: (out / "episodes" / f"e{k:04d}" / "record.json").stat().st_mtime_ns for k in kept} == kept
