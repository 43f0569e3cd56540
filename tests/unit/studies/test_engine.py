"""The engine (`services.studies.engine.run_tasks`): order, resume, refusals, errors, teardown.

One Dask cluster is shared by the module's tests (`cluster`, reached by address); the tests of
the local cluster that `run_tasks` starts itself (loopback, teardown) pay their own start-up."""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import psutil
import pytest

from services.studies import engine
from services.studies.engine import EngineError, EngineUsageError, normalise_address, run_tasks
from services.runtime.testing import wait_until
from services.studies.engine_checkpoint import Checkpoint
from tests.unit.studies import engine_tasks as T

ROOT = Path(__file__).resolve().parents[3]


def _alive(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def _our_children() -> set[int]:
    return {p.pid for p in psutil.Process().children(recursive=True) if not engine._is_helper(p)}


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address="127.0.0.1:0",
                      silence_logs=40) as c:
        yield c.scheduler_address


def test_results_come_back_in_argument_order(cluster):
    args = [(x, 0.05 * ((7 - x) % 4)) for x in range(8)]
    assert run_tasks(T.square_after, args, address=cluster, show_progress=False) == [x * x for x in range(8)]
    assert run_tasks(T.square_after, args, workers=1, show_progress=False) == [x * x for x in range(8)]
    assert run_tasks(T.square_after, [], address=cluster, show_progress=False) == []


def test_a_raising_task_names_its_argument_and_the_error(cluster):
    for where in ({"address": cluster}, {"workers": 1}):
        with pytest.raises(EngineError) as err:
            run_tasks(T.fails_on_three, range(6), show_progress=False, **where)
        text = str(err.value)
        assert "task 3 failed on argument 3: KeyError" in text and "no such key for three" in text
        assert isinstance(err.value.task_error, KeyError) and not err.value.bad_input


@pytest.mark.parametrize("where", ["cluster", "here"])
def test_resume_skips_finished_tasks_and_gives_identical_results(tmp_path, cluster, where):
    opts = {"address": cluster} if where == "cluster" else {"workers": 1}
    log = tmp_path / "calls.log"
    args = [(x, str(log)) for x in range(10)]
    reference = [T.counted((x, str(tmp_path / "ref.log"))) for x in range(10)]
    ckpt = tmp_path / "run" / "tasks.ckpt"
    (tmp_path / "fail-6").write_text("")
    with pytest.raises(EngineError, match="task 6 failed"):
        run_tasks(T.counted, args, checkpoint_path=ckpt, show_progress=False, **opts)
    first = [int(v) for v in log.read_text().split()]
    with ckpt.open("rb") as fh:
        pickle.load(fh)  # the header
        kept = []
        while True:
            try:
                kept.append(pickle.load(fh)[0])
            except EOFError:
                break
    assert 6 not in kept and set(kept) <= set(first) and (where == "cluster" or kept == list(range(6)))
    (tmp_path / "fail-6").unlink()
    log.write_text("")
    results = run_tasks(T.counted, args, checkpoint_path=ckpt, show_progress=False, **opts)
    assert sorted(int(v) for v in log.read_text().split()) == sorted(set(range(10)) - set(kept))
    assert results == [{**r} for r in reference]
    log.write_text("")  # a finished run: nothing runs again, same results
    assert run_tasks(T.counted, args, checkpoint_path=ckpt, show_progress=False, **opts) == results
    assert log.read_text() == ""


def test_a_checkpoint_of_other_arguments_is_refused_and_left_alone(tmp_path):
    ckpt = tmp_path / "c.ckpt"
    args = [(x, 0.0) for x in range(4)]
    run_tasks(T.square_after, args, workers=1, checkpoint_path=ckpt, show_progress=False)
    before = ckpt.read_bytes()
    cases = [(T.square_after, [(x, 0.0) for x in range(5)], "is for 4 tasks, this run has 5"),
             (T.square_after, [(0, 0.0), (9, 0.0), (2, 0.0), (3, 0.0)], "task 1 differs"),
             (T.fails_on_three, args, "holds results of tests.unit.studies.engine_tasks:square_after")]
    for function, other, words in cases:
        with pytest.raises(EngineUsageError, match=words) as err:
            run_tasks(function, other, workers=1, checkpoint_path=ckpt, show_progress=False)
        assert err.value.bad_input and f"delete {ckpt}" in str(err.value)
    assert ckpt.read_bytes() == before
    junk = tmp_path / "junk.ckpt"
    junk.write_bytes(b"not a pickle at all")
    with pytest.raises(EngineUsageError, match="is not an engine checkpoint"):
        run_tasks(T.square_after, args, workers=1, checkpoint_path=junk, show_progress=False)


def test_a_torn_last_record_is_cut_off_and_rerun(tmp_path):
    ckpt, log = tmp_path / "c.ckpt", tmp_path / "calls.log"
    args = [(x, str(log)) for x in range(5)]
    run_tasks(T.counted, args, workers=1, checkpoint_path=ckpt, show_progress=False)
    whole = ckpt.read_bytes()
    ckpt.write_bytes(whole[:-7])  # a crash in the middle of the last record's write
    log.write_text("")
    assert run_tasks(T.counted, args, workers=1, checkpoint_path=ckpt, show_progress=False)[4]["cube"] == 64
    assert log.read_text().split() == ["4"] and ckpt.read_bytes() == whole


def test_a_record_that_cannot_be_loaded_is_refused_not_cut_off(tmp_path):
    """Only a torn last record (a crash while writing) is cut off. A whole record that does not
    load (its result's class renamed since the run) must not make the checkpoint drop it and
    every record after it: the resume is refused and the file left as it is."""
    ckpt = tmp_path / "c.ckpt"
    run_tasks(T.unloadable_on_one, range(4), workers=1, checkpoint_path=ckpt, show_progress=False)
    whole = ckpt.read_bytes()
    with pytest.raises(EngineUsageError, match="cannot be loaded"):
        run_tasks(T.unloadable_on_one, range(4), workers=1, checkpoint_path=ckpt, show_progress=False)
    assert ckpt.read_bytes() == whole


def test_the_local_cluster_listens_on_loopback_and_is_torn_down(tmp_path):
    before = _our_children()
    seen = run_tasks(T.whereabouts, [os.getpid()] * 4, workers=2, show_progress=False)
    assert {s["listening"][0] for s in seen} == {"127.0.0.1"} and all(len(s["listening"]) == 1 for s in seen)
    workers = {s["pid"] for s in seen}
    assert len(workers) <= 2 and not workers & before and {s["parent"] for s in seen} == {os.getpid()}
    assert _our_children() == before and not any(_alive(p) for p in workers)
    with pytest.raises(EngineError, match="task 3 failed"):  # also after a failing task
        run_tasks(T.fails_on_three, range(6), workers=2, show_progress=False)
    assert _our_children() == before


def test_a_tasks_own_child_does_not_outlive_the_local_cluster(tmp_path):
    """A task that starts a process (an evaluation episode's launcher, in a session of its
    own) and is still running when the call ends: the child must go with the cluster, not be
    left behind, re-parented to init, once its worker is gone."""
    with pytest.raises(EngineError, match="told to fail"):
        run_tasks(T.child_or_failure, [(0, str(tmp_path)), (1, str(tmp_path))], workers=2, show_progress=False)
    children = [int(p.name.split("-")[1]) for p in tmp_path.glob("child-*")]
    assert len(children) == 1
    assert wait_until(lambda: not _alive(children[0]), 10.0), "the task's child is still running"


def _args_of(folder: Path) -> list:
    return [(x, str(folder)) for x in range(200)]


def test_ctrl_c_tears_the_local_cluster_down_and_keeps_the_checkpoint(tmp_path):
    ckpt = tmp_path / "c.ckpt"
    script = textwrap.dedent(f"""
        from services.studies.engine import run_tasks
        from tests.unit.studies.engine_tasks import slow_pid
        if __name__ == "__main__":
            run_tasks(slow_pid, [(x, {str(tmp_path)!r}) for x in range(200)], workers=2,
                      checkpoint_path={str(ckpt)!r}, show_progress=False)
    """)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT, env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        # Both workers have run tasks, and finished results are in the checkpoint (a loaded
        # machine may take a while for either).
        while time.monotonic() < deadline and (len(list(tmp_path.glob("done-*"))) < 4
                                               or len(list(tmp_path.glob("pid-*"))) < 2
                                               or not ckpt.exists() or ckpt.stat().st_size == 0):
            time.sleep(0.1)
        time.sleep(0.5)
        family = {p.pid for p in psutil.Process(proc.pid).children(recursive=True)}
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    workers = {int(p.name.split("-")[1]) for p in tmp_path.glob("pid-*")}
    assert proc.returncode != 0 and b"KeyboardInterrupt" in proc.stderr.read()
    assert len(workers) == 2 and workers <= family
    # Nothing left running (a worker being reaped as the call returns gets a few seconds).
    assert wait_until(lambda: not [p for p in family if _alive(p)], 10.0), [p for p in family if _alive(p)]
    kept = Checkpoint.open(ckpt, T.slow_pid, _args_of(tmp_path))
    kept.close()
    assert 1 <= len(kept.done) < 200 and all(kept.done[i] == i for i in kept.done)


@pytest.mark.parametrize("text, expected", [("10.0.0.5:8786", "tcp://10.0.0.5:8786"),
                                            ("tcp://node-1.lab:8786", "tcp://node-1.lab:8786"),
                                            ("tls://[::1]:9000", "tls://[::1]:9000")])
def test_address_forms(text, expected):
    assert normalise_address(text) == expected


@pytest.mark.parametrize("text", ["8786", "http://a:1", "a:99999", "a b:1", ""])
def test_bad_address_forms_are_usage_errors(text):
    with pytest.raises(EngineUsageError, match="is not HOST:PORT"):
        run_tasks(T.fails_on_three, [1], address=text, show_progress=False)


def test_workers_with_an_address_and_an_unreachable_cluster(monkeypatch):
    with pytest.raises(EngineUsageError, match="drop --workers"):
        run_tasks(T.fails_on_three, [1], address="127.0.0.1:1", workers=2, show_progress=False)
    monkeypatch.setattr(engine, "CONNECT_TIMEOUT_S", 1.0)
    t0 = time.monotonic()
    with pytest.raises(EngineError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:1") as err:
        run_tasks(T.fails_on_three, [1], address="127.0.0.1:1", show_progress=False)
    assert not err.value.bad_input and time.monotonic() - t0 < 15


def test_a_local_run_says_nothing_when_all_is_well():
    """The local cluster's scheduler runs in the caller's process: its INFO lines (and the
    traceback Dask logs when a comm closes at teardown) stay off the console."""
    script = textwrap.dedent("""
        from services.studies.engine import run_tasks
        from tests.unit.studies import engine_tasks as T
        print(run_tasks(T.square_after, [(3, 0.0), (4, 0.0)], workers=1, show_progress=False))
    """)
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[9, 16]"
    assert "distributed" not in done.stderr and "Traceback" not in done.stderr, done.stderr
