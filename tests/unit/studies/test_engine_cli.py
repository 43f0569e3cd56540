"""The engine's flags in the commands that run on it: `handover-contact batch` and
`handover-study bench` accept --address, --workers and --checkpoint, with one-line errors."""

from __future__ import annotations

import json

import pytest

from services.studies import engine
from services.studies.cli import main as study_main
from services.studies.contact_command import main as contact_main

CONTACT = ["batch", "--behaviour", "dropping", "-n", "8", "--chunk-size", "4", "--duration-s", "1.0", "--no-progress"]
BENCH = ["bench", "--controllers", "HI", "-n", "4", "--chunk-size", "2", "--no-plots", "--no-oracle", "--no-progress"]


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err, err
    return err


@pytest.mark.parametrize("run, argv", [(contact_main, CONTACT), (study_main, BENCH)])
def test_a_malformed_address_is_a_usage_error(run, argv, capsys):
    for bad in (["--address", "no-port"], ["--address", "host:70000"], ["--address", "a:1", "--workers", "2"]):
        with pytest.raises(SystemExit) as exc:
            run(argv + bad)
        assert exc.value.code == 2
        err = _one_line(capsys)
        assert "is not HOST:PORT" in err or "not allowed with argument" in err


@pytest.mark.parametrize("run, argv", [(contact_main, CONTACT), (study_main, BENCH)])
def test_an_unreachable_cluster_is_a_runtime_error(run, argv, capsys, monkeypatch, tmp_path):
    monkeypatch.setattr(engine, "CONNECT_TIMEOUT_S", 1.0)
    assert run(argv + ["--address", "127.0.0.1:1"] + (["--out", str(tmp_path)] if run is study_main else [])) == 1
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:1" in _one_line(capsys)


def test_contact_batch_resumes_from_its_checkpoint_and_refuses_other_arguments(tmp_path, capsys):
    ckpt, first, again = tmp_path / "ckpt", tmp_path / "a.json", tmp_path / "b.json"
    assert contact_main(CONTACT + ["--workers", "1", "--checkpoint", str(ckpt), "--json", str(first)]) == 0
    assert (ckpt / "batch.ckpt").stat().st_size > 0
    assert contact_main(CONTACT + ["--checkpoint", str(ckpt), "--json", str(again)]) == 0
    a, b = json.loads(first.read_text()), json.loads(again.read_text())
    assert {k: v for k, v in a.items() if k not in ("wall_time_s", "episodes_per_s", "workers")} == \
        {k: v for k, v in b.items() if k not in ("wall_time_s", "episodes_per_s", "workers")}
    capsys.readouterr()
    assert contact_main(CONTACT + ["--seed", "3", "--checkpoint", str(ckpt)]) == 2
    assert "was written with other arguments" in _one_line(capsys)


def test_bench_checkpoint_refuses_other_arguments(tmp_path, capsys):
    ckpt = tmp_path / "ckpt"
    out = ["--out", str(tmp_path / "out"), "--checkpoint", str(ckpt), "--workers", "1"]
    assert study_main(BENCH + out) == 0
    assert (ckpt / "bench.ckpt").exists()
    capsys.readouterr()
    assert study_main(BENCH + ["--seed", "5"] + out) == 2
    assert "handover-study bench: error: the checkpoint" in _one_line(capsys)
