"""Paths a command writes are checked before anything starts (`services.runtime.paths`)."""

from __future__ import annotations

import time

from services.recorder.cli import main as recorder_main
from services.runtime.paths import unwritable_dir


def test_a_folder_that_cannot_be_made_or_written_is_named(tmp_path):
    assert unwritable_dir(tmp_path / "new" / "deeper") is None and (tmp_path / "new" / "deeper").is_dir()
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    assert unwritable_dir(blocker / "sub") == "Not a directory"
    assert unwritable_dir(blocker) is not None


def test_the_recorder_refuses_an_unwritable_output_before_it_looks_for_the_bus(tmp_path, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    t0 = time.monotonic()
    code = recorder_main(["--output", str(blocker / "run.rrd"), "--endpoint", "tcp/127.0.0.1:9"])
    assert code == 2 and time.monotonic() - t0 < 5.0  # no 10 s wait for a router
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write a recording into" in err[0] and "(File exists)" in err[0]
    assert blocker.read_text() == "x"
