"""An evaluation episode interrupted mid-run is run again on --resume, not recorded as a
failure: a launcher killed outright (`run_stack` kills it on Ctrl-C; a worker's end, the OOM
killer) cannot delete its run's logins folder, and a new launcher with the same run id refuses
to start beside it."""

from __future__ import annotations

from pathlib import Path

import pytest

from services.studies.evaluation.runner import STACK_ERROR, EpisodeTask, episode_dir, run_episode, run_id

pytestmark = pytest.mark.integration

REPO = Path(__file__).resolve().parents[2]


def test_an_episode_whose_launcher_was_killed_runs_again_on_resume(tmp_path):
    task = EpisodeTask(str(tmp_path), 0, 11, str(REPO / "deploy" / "sim.toml"), timeout_s=180.0, clock="sim")
    folder = episode_dir(tmp_path, 0)
    # What a SIGKILLed launcher leaves: its logins folder (and no record.json).
    stale = folder / f"handover-{run_id(0)}-bus"
    stale.mkdir(parents=True)
    (stale / "credentials").write_text("launcher:old-password\n")
    record = run_episode(task)
    console = (folder / "console.txt").read_text()
    assert "exists already" not in console, console[-2000:]
    assert record["outcome"] != STACK_ERROR, record["reason"]
    assert record["outcome"] != "no_summary", record["reason"]
    assert not stale.exists()  # the new launcher removed its own folder at its exit
