"""`handover-study`: the tracker studies end to end, and bad input."""

from __future__ import annotations

import json

import pytest

from bus_schema import topics as T
from services.studies.cli import main as study_main
from services.tracker.cli import main as tracker_main
from services.tracker.replay import read_replay


def test_record_writes_a_replay_that_the_tracker_reads_back(tmp_path, capsys):
    path = tmp_path / "episode.bin"
    assert study_main(["record", "--out", str(path), "--seed", "3"]) == 0
    said = capsys.readouterr().out
    frames = int(said.split(": ")[1].split(" frames")[0])
    topics = [item.topic for item in read_replay(path)]
    assert frames > 50
    for topic in (T.JOINT_STATE, T.DEPTH, T.SKELETON, T.SIM_TRUTH):
        assert topics.count(topic) == frames
    assert tracker_main(["offline", str(path)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["skeleton_frames"] == frames
    assert summary["tracked_frames"] > frames // 2
    assert 10.0 < summary["hand_error_mm"]["corrected_median"] < 300.0


def test_evaluate_writes_the_numbers_of_the_library(tmp_path, capsys):
    from services.studies.tracker.evaluate import run_evaluation
    from services.tracker.config import config_from_dict

    out = tmp_path / "evaluation.json"
    assert study_main(["evaluate", "--episodes", "1", "--seed", "2", "--json", str(out)]) == 0
    assert "| both (a)+(b) |" in capsys.readouterr().out
    written = json.loads(out.read_text())
    summary, _ = run_evaluation(1, 2, config_from_dict({}))
    assert (written["episodes"], written["first_seed"]) == (1, 2)
    assert written["summary"] == json.loads(json.dumps(summary))


def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    assert study_main(["record", "--out", str(tmp_path / "missing" / "x.bin")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("handover-study record: error:") and err.count("\n") == 1
    assert not (tmp_path / "missing").exists()
    a_file = tmp_path / "file"
    a_file.write_text("")
    assert study_main(["figures", "planner", "--out", str(a_file)]) == 2
    assert "is not a folder" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        study_main(["evaluate", "--episodes", "0"])
    assert exit_info.value.code == 2
    with pytest.raises(SystemExit) as exit_info:
        study_main([])
    assert exit_info.value.code == 2
