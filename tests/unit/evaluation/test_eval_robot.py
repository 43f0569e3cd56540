"""`handover-eval run --robot`: every episode's profile names the arm, the DJT reference uses that
arm's giver stand-in, and a resumed run keeps its arm."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from handover_model import robots
from services.runtime.profile import load_profile_file
from services.studies.evaluation.cli import main as eval_main
from services.studies.evaluation.djt_reference import djt_optimum_base_m
from services.studies.evaluation.episode_profile import read_base_profile, write_episode_profile
from services.studies.evaluation.errors import EvaluationError
from services.studies.evaluation.population import draw_episode
from services.studies.evaluation.run import RunOptions, _manifest


def _tall_draw():
    return dataclasses.replace(draw_episode(1, 36), posture="standing", height_m=1.75)


def test_the_episode_profile_names_the_arm_and_replaces_the_base_robot_table(tmp_path, monkeypatch):
    monkeypatch.delenv(robots.ROBOT_ENV, raising=False)
    _path, base = read_base_profile("sim")
    base = {**base, "robot": {"model": "baxter", "velocity_scale": 0.5}}  # overrides for another arm
    path = write_episode_profile(base, _tall_draw(), tmp_path / "p.toml", "panda")
    doc = tomllib.loads(path.read_text())
    assert doc["robot"] == {"model": "panda"}
    load_profile_file(path)
    assert robots.from_profile(doc).name == "panda"
    as_base = tomllib.loads(write_episode_profile(read_base_profile("sim")[1], _tall_draw(),
                                                  tmp_path / "q.toml").read_text())
    assert as_base["robot"] == {"model": "baxter"}  # no --robot: the base profile's table as it is


def test_the_djt_reference_uses_the_arms_giver_stand_in():
    draw = _tall_draw()
    baxter = djt_optimum_base_m(draw, {}, robots.describe("baxter"))
    panda = djt_optimum_base_m(draw, {}, robots.describe("panda"))
    assert baxter is not None and panda is not None
    np.testing.assert_allclose(djt_optimum_base_m(draw, {}), baxter)  # no arm given: Baxter's, as before
    assert robots.describe("panda").giver != robots.describe("baxter").giver
    assert np.linalg.norm(panda - baxter) > 0.01, (panda, baxter)


def _options(out: Path, robot: str | None, resume: bool) -> RunOptions:
    return RunOptions(out=out, episodes=None if resume else 2, seed=None, profile=None, workers=1, address=None,
                      timeout_s=60.0, resume=resume, robot=robot)


def test_a_resumed_run_keeps_its_arm(tmp_path):
    manifest = _manifest(_options(tmp_path, "ur5", resume=False))
    assert manifest["robot"] == "ur5"
    (tmp_path / "manifest.json").write_text(__import__("json").dumps(manifest))
    assert _manifest(_options(tmp_path, None, resume=True))["robot"] == "ur5"
    assert _manifest(_options(tmp_path, "ur5", resume=True))["robot"] == "ur5"
    with pytest.raises(EvaluationError, match="--robot panda differs") as exc:
        _manifest(_options(tmp_path, "panda", resume=True))
    assert exc.value.bad_input


def test_an_unknown_arm_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        eval_main(["run", "--episodes", "1", "--robot", "kuka"])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err
