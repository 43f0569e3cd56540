"""The launcher's monitor sleeps until something happens (issue 16: it polled at 50 Hz): a
child's exit wakes it through the child's process file descriptor, a stop or a liveliness
change through an eventfd, and nothing else does before the back-stop time-out."""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import psutil
import pytest

from services.launcher.wakeup import MonitorWakeup, WakingEvent


@pytest.fixture
def wakeup():
    w = MonitorWakeup()
    yield w
    w.close()


def _sleeper(seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])


def test_a_child_exit_ends_the_wait_at_once_and_stays_until_forgotten(wakeup):
    child = _sleeper(0.3)
    try:
        wakeup.watch("motion", child.pid)
        t0 = time.monotonic()
        exited = wakeup.wait(5.0)
        waited_s = time.monotonic() - t0
        assert exited == {"motion"}
        assert 0.1 < waited_s < 3.0, waited_s          # it slept until the exit, not to the time-out
        assert child.wait(1.0) == 0
        assert wakeup.wait(5.0) == {"motion"}           # reaped or not: ended until forgotten
        wakeup.forget("motion")
        t0 = time.monotonic()
        assert wakeup.wait(0.2) == set()
        assert time.monotonic() - t0 >= 0.15            # nothing left to wake it
    finally:
        child.kill()
        child.wait()


def test_a_wake_ends_the_wait_once_and_is_cleared(wakeup):
    threading.Timer(0.2, wakeup.wake).start()
    t0 = time.monotonic()
    assert wakeup.wait(5.0) == set()
    assert 0.1 < time.monotonic() - t0 < 3.0
    t0 = time.monotonic()
    assert wakeup.wait(0.2) == set()                    # the wake was taken: this one times out
    assert time.monotonic() - t0 >= 0.15


def test_a_waking_event_set_from_another_thread_ends_the_wait(wakeup):
    stop = WakingEvent(wakeup)
    threading.Timer(0.2, stop.set).start()
    t0 = time.monotonic()
    wakeup.wait(5.0)
    assert stop.is_set() and time.monotonic() - t0 < 3.0
    assert stop.wait(0.0)                               # still an Event for everyone else


def _switches(tid: int) -> int:
    """Voluntary context switches of thread `tid` of this process (each a sleep and a wake)."""
    with open(f"/proc/self/task/{tid}/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith("voluntary_ctxt_switches"))


def test_a_running_child_does_not_wake_the_sleeping_monitor(wakeup):
    child = _sleeper(30.0)
    tids: list[int] = []

    def monitor() -> None:
        tids.append(threading.get_native_id())
        wakeup.wait(30.0)

    try:
        wakeup.watch("bridge", child.pid)
        waiter = threading.Thread(target=monitor)
        waiter.start()
        time.sleep(0.3)
        before = _switches(tids[0])
        time.sleep(0.8)
        assert waiter.is_alive()
        assert _switches(tids[0]) - before == 0         # the old loop woke 40 times in 0.8 s
        wakeup.wake()
        waiter.join(5.0)
        assert not waiter.is_alive()
    finally:
        child.kill()
        child.wait()


def test_a_child_the_kernel_cannot_watch_is_looked_at_as_often_as_before(wakeup):
    child = _sleeper(0.0)
    child.wait()
    gone_pid = child.pid
    while psutil.pid_exists(gone_pid):
        time.sleep(0.01)
    wakeup.watch("planner", gone_pid)                   # no such process: not watched, no error
    t0 = time.monotonic()
    assert wakeup.wait(5.0) == set()
    assert time.monotonic() - t0 < 1.0                  # UNWATCHED_POLL_S, not the 5 s asked for
    wakeup.forget("planner")
    t0 = time.monotonic()
    assert wakeup.wait(0.2) == set()
    assert time.monotonic() - t0 >= 0.15


def test_after_close_wake_does_nothing_and_wait_returns_at_once():
    w = MonitorWakeup()
    w.close()
    w.close()                                           # once is enough; twice is harmless
    w.wake()
    t0 = time.monotonic()
    assert w.wait(5.0) == set()
    assert time.monotonic() - t0 < 1.0


def test_the_launcher_monitor_sleeps_until_its_child_exits_then_fails_the_run(tmp_path, monkeypatch):
    """`Launcher._monitor` with a real child standing in for the bridge (never restarted): no
    wake while it runs, even with a 30 s back-stop; its exit ends the monitor at once with the
    run's failure and the stop request."""
    from services.launcher import node, wakeup as wakeup_module
    from services.launcher.core import LaunchOptions
    from services.launcher.processes import Child
    from services.runtime.profile import load_profile_file

    monkeypatch.setattr(wakeup_module, "BACKSTOP_S", 30.0)
    launcher = node.Launcher(load_profile_file("sim"), LaunchOptions(run_id="t", recording_dir=tmp_path))

    class Watcher:
        def events(self) -> list:
            return []

    child = Child("bridge", [sys.executable, "-c", "import sys, time; time.sleep(1.2); sys.exit(3)"], 10,
                  verbose=False)
    child.start()
    tids: list[int] = []

    def monitor() -> None:
        tids.append(threading.get_native_id())
        launcher._monitor(Watcher())

    try:
        launcher.children["bridge"] = child
        assert child.pid is not None
        launcher.wakeup.watch("bridge", child.pid)
        thread = threading.Thread(target=monitor)
        thread.start()
        time.sleep(0.3)
        before = _switches(tids[0])
        time.sleep(0.5)
        assert thread.is_alive() and _switches(tids[0]) - before == 0
        thread.join(10.0)
        assert not thread.is_alive()                    # ended by the exit, not by the 30 s back-stop
        assert launcher.stop_requested.is_set()
        assert launcher.failure is not None and "bridge" in launcher.failure, launcher.failure
        assert "bridge" not in launcher.children
    finally:
        if child.proc is not None:
            child.proc.kill()
            child.proc.wait()
        launcher.wakeup.close()
