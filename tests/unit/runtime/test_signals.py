"""`SignalRelay`: a stop signal that lands while the main thread holds the lock its handler
would take must still stop the process (CI once hung on it: the recorder logged "received
SIGINT" and never stopped). Each scenario runs in a child process: a hang is a time-out there,
not a hung test run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest

from services.runtime.signals import SignalRelay

ROOT = Path(__file__).resolve().parents[3]

#: The main thread holds `stop`'s own lock (as `Event.wait` does around its sleep) when the
#: signal comes, and keeps it until the handler has run; then it waits for `stop`.
LOCK_HELD_WHEN_SIGNALLED = """
import os, signal, sys, threading, time
stop = threading.Event()
{install}
with stop._cond:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.3)  # the Python-level handler runs here, in this thread, the lock held
print("set" if stop.wait(5.0) else "not set", flush=True)
"""


def _run(script: str, timeout_s: float = 10.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(script)], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout_s)


def test_a_handler_that_sets_the_event_itself_hangs_there():
    """The premise: the old way (the handler calls `set`) deadlocks in this scenario."""
    script = LOCK_HELD_WHEN_SIGNALLED.format(install="signal.signal(signal.SIGINT, lambda s, f: stop.set())")
    with pytest.raises(subprocess.TimeoutExpired):
        _run(script, timeout_s=4.0)


def test_the_relay_stops_the_process_although_the_lock_was_held():
    install = ("from services.runtime.signals import SignalRelay\n"
               "SignalRelay(lambda signum: stop.set()).install()")
    done = _run(LOCK_HELD_WHEN_SIGNALLED.format(install=install))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "set"


def test_on_signal_gets_the_number_in_the_relay_thread_and_restore_puts_the_old_handler_back():
    before = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    got: list[tuple[int, str]] = []
    arrived = threading.Event()

    def on_signal(signum: int) -> None:
        got.append((signum, threading.current_thread().name))
        arrived.set()

    relay = SignalRelay(on_signal, name="relay under test")
    fds_before = sorted(os.listdir("/proc/self/fd"))
    assert relay.install() and relay.installed
    assert relay.install()  # idempotent: one thread, one pipe
    try:
        assert signal.getsignal(signal.SIGTERM) != before[signal.SIGTERM]
        os.kill(os.getpid(), signal.SIGTERM)
        assert arrived.wait(5.0)
        assert got == [(signal.SIGTERM, "relay under test")]
    finally:
        relay.restore()
    assert not relay.installed
    assert {sig: signal.getsignal(sig) for sig in before} == before
    assert not any(t.name == "relay under test" for t in threading.enumerate())
    # Both ends of the pipe closed: no descriptor the relay opened is left. (Only new ones
    # count: a Zenoh session of an earlier test may close its sockets meanwhile.)
    assert set(os.listdir("/proc/self/fd")) - set(fds_before) == set()
    relay.restore()  # idempotent


def test_a_failing_on_signal_is_logged_and_the_next_signal_still_comes_through(caplog):
    got: list[int] = []
    second = threading.Event()

    def on_signal(signum: int) -> None:
        got.append(signum)
        if len(got) == 1:
            raise OSError("log file gone")
        second.set()

    relay = SignalRelay(on_signal, signals=(signal.SIGUSR1,), name="failing relay")
    relay.install()
    try:
        os.kill(os.getpid(), signal.SIGUSR1)
        assert wait_for(lambda: len(got) == 1)
        os.kill(os.getpid(), signal.SIGUSR1)
        assert second.wait(5.0)
    finally:
        relay.restore()
    assert got == [signal.SIGUSR1, signal.SIGUSR1]
    assert "failing relay: acting on signal" in caplog.text and "log file gone" in caplog.text


def wait_for(condition, timeout_s: float = 5.0) -> bool:
    import time

    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.005)
    return True


def test_install_outside_the_main_thread_changes_nothing():
    before = signal.getsignal(signal.SIGINT)
    outcome: list[bool] = []
    relay = SignalRelay(lambda _s: None)
    worker = threading.Thread(target=lambda: outcome.append(relay.install()))
    worker.start()
    worker.join(5.0)
    assert outcome == [False]
    assert not relay.installed
    assert signal.getsignal(signal.SIGINT) is before


def test_every_signal_reaches_on_signal_with_its_own_number():
    """Forty signals of two kinds, each acted on in the relay thread before the next is sent."""
    script = """
    import os, signal, threading
    from services.runtime.signals import SignalRelay
    got, arrived = [], threading.Semaphore(0)
    def on_signal(signum):
        got.append(signum)
        arrived.release()
    relay = SignalRelay(on_signal, signals=(signal.SIGUSR1, signal.SIGUSR2))
    relay.install()
    for i in range(20):
        for sig in (signal.SIGUSR1, signal.SIGUSR2):
            os.kill(os.getpid(), sig)
            if not arrived.acquire(timeout=5.0):
                raise SystemExit(f"signal {len(got) + 1} not relayed")
    relay.restore()
    print(",".join(str(s) for s in got))
    """
    done = _run(script)
    assert done.returncode == 0, done.stderr
    expected = ",".join([f"{int(signal.SIGUSR1)},{int(signal.SIGUSR2)}"] * 20)
    assert done.stdout.strip() == expected


def test_a_service_node_stops_on_sigint_that_lands_while_its_main_thread_holds_the_stop_lock():
    """`ServiceNode` on a real bus: the same scenario through its own handler. Before the relay,
    its handler logged and called `stop_event.set()` in the main thread, and hung here."""
    from services.runtime.testing import BusRouter, free_tcp_port, loopback_profile

    port = free_tcp_port()
    script = f"""
    import logging, os, signal, time
    from services.runtime.node import ServiceNode
    logging.basicConfig(level=logging.INFO)
    from services.runtime.testing import loopback_profile
    with ServiceNode("probe", loopback_profile({port})) as node:
        with node.stop_event._cond:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.3)
        print("stopped" if node.stop_event.wait(5.0) else "running", flush=True)
    """
    with BusRouter(loopback_profile(port)):
        done = _run(script, timeout_s=30.0)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "stopped"
    assert "probe received SIGINT, shutting down" in done.stderr
