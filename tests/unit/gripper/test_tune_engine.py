"""`handover-study tune` on the studies' engine (tuning.engine_runner, engine.open_cluster; the
default): each generation's chunks run as engine tasks and give the same scores, bit for bit, as
the in-process path, on a real local Dask cluster and in this process (`--workers 1`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from services.studies.cli import main as study_main
from services.studies.engine import EngineUsageError, open_cluster
from services.studies.gripper.oracle_family import bench_chunks
from services.studies.gripper.populations import population
from services.studies.gripper.tuning import engine_runner, evaluate

SETS = [{}, {"hold_per_weight": 9.0, "release_share": 0.3, "max_hold_force_n": 30.0}]


@pytest.fixture(scope="module")
def chunks():
    return bench_chunks(1000, 24, 12, population("wide", ["slow"]))  # 2 chunks of 12 episodes


def _same(a, b) -> None:
    for field in ("failed", "dropped", "handed_over", "overshoot_n", "release_time_s"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)  # NaN == NaN here


def test_engine_scores_equal_the_in_process_scores_bit_for_bit(chunks):
    here = evaluate(chunks, "SG", SETS)
    assert here.failed.shape == (2, 24)
    assert not np.array_equal(np.nan_to_num(here.overshoot_n[0]), np.nan_to_num(here.overshoot_n[1]))
    with open_cluster(workers=2) as client:
        assert client is not None  # a real local cluster of two worker processes
        on_cluster = evaluate(chunks, "SG", SETS, engine_runner(client))
        again = evaluate(chunks, "SG", SETS[::-1], engine_runner(client))  # a second call, same cluster
    _same(here, on_cluster)
    # Another order of the sets is another batch layout (sensor noise is drawn per batch position), but
    # each chunk's batch is still exactly what the in-process path computes for that order.
    _same(evaluate(chunks, "SG", SETS[::-1]), again)


def test_one_worker_runs_in_this_process_with_the_same_scores(chunks):
    with open_cluster(workers=1) as client:
        assert client is None
        _same(evaluate(chunks[:2], "HI", [{}]), evaluate(chunks[:2], "HI", [{}], engine_runner(client)))


def test_open_cluster_refuses_workers_with_an_address():
    with pytest.raises(EngineUsageError, match="drop --workers"):
        with open_cluster("127.0.0.1:8786", workers=2):
            pass


def test_cli_on_a_local_cluster_gives_the_in_process_result(tmp_path):
    common = ["tune", "--controller", "HI", "-n", "12", "--chunk-size", "6", "--population", "narrow", "--budget", "5",
              "--popsize", "4", "--quiet"]
    assert study_main(common + ["--workers", "1", "--out", str(tmp_path / "here.json")]) == 0
    assert study_main(common + ["--workers", "2", "--out", str(tmp_path / "engine.json")]) == 0
    here, engine = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("here", "engine"))
    assert engine["best_params"] == here["best_params"] and engine["best_rerun"] == here["best_rerun"]
    assert [h["objective_min"] for h in engine["history"]] == [h["objective_min"] for h in here["history"]]


def test_cli_workers_with_address_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        study_main(["tune", "--controller", "HI", "--workers", "2", "--address", "127.0.0.1:8786"])
    assert exc.value.code == 2 and "not allowed with" in capsys.readouterr().err


def test_cli_tune_has_no_checkpoint_flag(capsys):
    with pytest.raises(SystemExit) as exc:
        study_main(["tune", "--controller", "HI", "--checkpoint", "x"])
    assert exc.value.code == 2 and "--checkpoint" in capsys.readouterr().err
