"""The activation census of the CPU benches (`tests/bench/activation_census.py`): thread kinds,
the counts over a window from a `/proc` tree, its table, and its command line."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest

from tests.bench import activation_census as ac


def _task(root: Path, pid: int, tid: int, comm: str, exec_ns: int, runs: int) -> None:
    task = root / str(pid) / "task" / str(tid)
    task.mkdir(parents=True, exist_ok=True)
    (task / "comm").write_text(comm + "\n")
    (task / "schedstat").write_text(f"{exec_ns} 0 {runs}\n")
    if tid == pid:
        (root / str(pid) / "comm").write_text(comm + "\n")


def test_threads_are_told_apart_by_id_and_name_whatever_the_process_is_called():
    assert ac.thread_kind(10, 10, "handover-up", "handover-up") == "Python main thread"
    assert ac.thread_kind(10, 11, "handover-up", "handover-up") == "other Python threads"
    assert ac.thread_kind(10, 12, "app-0", "handover-up") == "Zenoh workers"
    assert ac.thread_kind(10, 13, "rx-1", "python") == "Zenoh workers"
    assert ac.thread_kind(10, 14, "file_writer", "python") == "other native threads"
    assert ac.thread_kind(10, 15, "app-0x", "python") == "other native threads"


def test_a_proc_tree_is_read_per_thread_and_a_gone_process_gives_nothing(tmp_path: Path):
    _task(tmp_path, 7, 7, "python", 2_000_000_000, 100)
    _task(tmp_path, 7, 8, "app-0", 500_000_000, 900)
    _task(tmp_path, 7, 9, "python", 100_000_000, 10)
    (tmp_path / "7" / "task" / "10").mkdir()  # a thread that ended while read: left out
    threads = ac.read_threads(7, str(tmp_path))
    assert threads == {7: ("Python main thread", ac.ThreadTotals(2.0, 100)),
                       8: ("Zenoh workers", ac.ThreadTotals(0.5, 900)),
                       9: ("other Python threads", ac.ThreadTotals(0.1, 10))}
    assert ac.read_threads(99, str(tmp_path)) == {}


def test_the_table_sums_per_kind_and_survives_a_window_without_runs():
    census = ac.Census(10.0, {("bridge", "Python main thread"): 0.06, ("bridge", "Zenoh workers"): 0.012,
                              ("router", "Zenoh workers"): 0.05},
                       {("bridge", "Python main thread"): 200.0, ("bridge", "Zenoh workers"): 300.0,
                        ("router", "Zenoh workers"): 1500.0})
    assert census.us_per_run(("bridge", "Python main thread")) == pytest.approx(300.0)
    assert census.by_kind()["Zenoh workers"] == pytest.approx((0.062, 1800.0))
    table = ac.rows(census)
    assert table[0][:3] == ("bridge", "Python main thread", "200")  # the busiest process first
    assert table[-1] == ("**all**", "**every thread**", "2000", "0.122", "61")
    empty = ac.rows(ac.Census(0.2, {("x", "Zenoh workers"): 0.0}, {("x", "Zenoh workers"): 0.0}))
    assert empty[-1][-1] == "—"


def test_a_live_census_counts_a_busy_thread_of_this_process():
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            sum(range(1000))

    worker = threading.Thread(target=spin)
    worker.start()
    try:
        census = ac.take_census({"me": os.getpid()}, 0.3)
    finally:
        stop.set()
        worker.join()
    assert census.cores[("me", "other Python threads")] > 0.05
    assert census.runs_per_s[("me", "Python main thread")] >= 1.0


@pytest.mark.parametrize("argv, message", [
    (["--launcher-pid", "1", "--seconds", "0"], "--seconds must be > 0"),
    (["--launcher-pid", "999999999", "--seconds", "1"], "no process 999999999"),
])
def test_bad_command_lines_are_refused_with_one_line_and_exit_2(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        ac.main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
