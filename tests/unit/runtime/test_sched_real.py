"""Starved or frozen: the run-queue judge (`services.runtime.sched`) on real busy loops: a loop
pinned beside a hog, a machine with every CPU busy, and a stopped process."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time

import pytest

from services.runtime.sched import MAX_EXCUSED_S, StarvationJudge


_SPIN = "import os, sys\nos.nice(int(sys.argv[1]))\nos.write(1, b'.')\nwhile True:\n    pass\n"


def _spinner(nice: int, cpu: int | None = None) -> subprocess.Popen:
    """A busy loop at niceness `nice`, on CPU `cpu` alone when given (wait for it with
    `_wait_spinning`)."""
    proc = subprocess.Popen([sys.executable, "-c", _SPIN, str(nice)], stdout=subprocess.PIPE)
    if cpu is not None:
        os.sched_setaffinity(proc.pid, {cpu})
    return proc


def _wait_spinning(procs: list[subprocess.Popen], timeout_s: float = 30.0) -> None:
    """Until every spinner has started its loop (its one byte on stdout): a spinner still
    starting up (reading its modules after a fresh install) is not yet on the run queue."""
    deadline = time.monotonic() + timeout_s
    for proc in procs:
        assert proc.stdout is not None
        ready, _, _ = select.select([proc.stdout], [], [], max(0.0, deadline - time.monotonic()))
        assert ready and proc.stdout.read(1) == b".", f"spinner {proc.pid} did not start within {timeout_s:g} s"


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs Linux CPU affinity")
def test_a_real_starved_process_is_excused_and_a_stopped_one_is_not():
    cpu = sorted(os.sched_getaffinity(0))[0]
    hog, starving, stopped = _spinner(0, cpu), _spinner(19, cpu), _spinner(0, cpu)
    try:
        _wait_spinning([hog, starving, stopped])
        time.sleep(0.1)
        stopped.send_signal(signal.SIGSTOP)
        judge = StarvationJudge()
        t0 = time.monotonic()
        for pid in (starving.pid, stopped.pid):
            judge.note(pid, t0)
        # The kernel adds a thread's run-queue wait when it next gets the CPU: a nice-19 loop
        # beside a nice-0 hog runs a few ms every ~0.2 s (longer on a loaded machine), so the
        # judge may have to look more than once.
        why, deadline = None, t0 + 3.0
        while why is None and time.monotonic() < deadline:
            time.sleep(0.1)
            why = judge.excuse(starving.pid, time.monotonic())
            assert judge.excuse(stopped.pid, time.monotonic()) is None, "a stopped process is frozen, not starved"
        assert why is not None, "a nice-19 loop sharing one CPU with a nice-0 hog waits on the run queue"
        assert MAX_EXCUSED_S <= 1.0
    finally:
        for proc in (hog, starving, stopped):
            proc.send_signal(signal.SIGCONT)
            proc.kill()
            proc.wait(5.0)
            if proc.stdout is not None:
                proc.stdout.close()


@pytest.mark.skipif(not os.path.exists("/proc/pressure/cpu"), reason="needs the kernel's CPU pressure (PSI)")
def test_on_a_saturated_machine_a_sleeping_process_is_excused_and_a_stopped_one_is_not():
    hogs = [_spinner(0) for _ in range(len(os.sched_getaffinity(0)) + 1)]
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    stopped = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        _wait_spinning(hogs)
        time.sleep(0.1)
        stopped.send_signal(signal.SIGSTOP)
        judge = StarvationJudge()
        t0 = time.monotonic()
        judge.tick(t0)
        time.sleep(0.3)
        now = time.monotonic()
        for pid in (sleeper.pid, stopped.pid):
            judge.note(pid, now, quiet_since_s=t0)
        why = judge.excuse(sleeper.pid, now)
        assert why is not None and "short of CPU" in why, judge.explain(sleeper.pid)
        assert judge.excuse(stopped.pid, now) is None
    finally:
        for proc in (*hogs, sleeper, stopped):
            proc.send_signal(signal.SIGCONT)
            proc.kill()
            proc.wait(5.0)
            if proc.stdout is not None:
                proc.stdout.close()
