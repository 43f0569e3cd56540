"""`handover-eval`: bad options are one line on stderr and exit 2, and change nothing."""

from __future__ import annotations

import json

import pytest

from services.studies.evaluation.cli import main


@pytest.mark.parametrize("argv, says", [
    (["run", "--episodes", "0", "--out", "{tmp}/a"], "--episodes"),
    (["run", "--episodes", "x", "--out", "{tmp}/a"], "--episodes"),
    (["run", "--episodes", "2", "--seed", "-1", "--out", "{tmp}/a"], "--seed"),
    (["run", "--episodes", "2", "--timeout-s", "5", "--out", "{tmp}/a"], "--timeout-s"),
    (["run", "--out", "{tmp}/a"], "--episodes is required"),
    (["run", "--episodes", "2", "--workers", "2", "--address", "10.0.0.5:8786", "--out", "{tmp}/a"], "exclude"),
    (["run", "--episodes", "2", "--profile", "baxter_fake", "--out", "{tmp}/a"], "simulated handover scene"),
    (["run", "--resume", "--out", "{tmp}/a"], "holds no evaluation run"),
    (["report", "--run", "{tmp}/a"], "holds no evaluation run"),
    (["replay", "--run", "{tmp}/a", "--episode", "0"], "holds no evaluation run"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_options_exit_2_with_one_line_and_make_nothing(argv, says, tmp_path, capsys):
    try:
        code = main([a.replace("{tmp}", str(tmp_path)) for a in argv])
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    err = capsys.readouterr().err.strip()
    assert code == 2 and says in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "a").exists()


def test_a_folder_with_a_run_is_not_overwritten_and_a_resume_keeps_its_seed(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "manifest.json").write_text(json.dumps({"seed": 4, "episodes": 2, "profile": "sim", "timeout_s": 240.0}))
    assert main(["run", "--episodes", "2", "--out", str(run)]) == 2
    assert "--resume" in capsys.readouterr().err
    assert main(["run", "--resume", "--seed", "5", "--out", str(run)]) == 2
    assert "differs from the resumed run's" in capsys.readouterr().err
    assert main(["replay", "--run", str(run), "--episode", "7"]) == 2
    assert "episodes 0–1" in capsys.readouterr().err
    assert main(["replay", "--run", str(run), "--episode", "1"]) == 2
    assert "has not run yet" in capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == ["manifest.json"]


def test_a_resume_accepts_the_runs_own_profile_by_name_and_says_a_legacy_runs_clock(tmp_path, capsys):
    """The manifest keeps the base profile's resolved path: `--profile sim` names the same file
    and must not be called different. A run from before `--clock` (no clock in its manifest)
    ran on the wall clock: `--clock sim` is refused in one line that says so, not a KeyError."""
    from services.runtime.profile import resolve_profile_path
    from services.studies.evaluation.run import RunOptions, _manifest

    run = tmp_path / "run"
    run.mkdir()
    sim = str(resolve_profile_path("sim").resolve())
    (run / "manifest.json").write_text(json.dumps({"seed": 4, "episodes": 2, "profile": sim, "timeout_s": 240.0}))
    options = RunOptions(out=run, episodes=None, seed=None, profile="sim", workers=1, address=None, timeout_s=240.0,
                         resume=True)
    assert _manifest(options)["profile"] == sim
    assert main(["run", "--resume", "--clock", "sim", "--out", str(run)]) == 2
    err = capsys.readouterr().err.strip()
    assert "--clock sim differs from the resumed run's (wall)" in err and len(err.splitlines()) == 1, err
