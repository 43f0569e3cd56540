"""Helpers for tests and benchmarks that run services as real processes on a loopback bus.

Everything here stops only what it started, by PID, even when the test fails.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import zenoh

from services.runtime.liveliness import alive_services
from services.runtime.node import open_session
from services.runtime.profile import Profile, free_tcp_port, load_profile_file
from services.runtime.zenoh_threads import ONE_WORKER_THREAD, ZENOH_RUNTIME_ENV


def loopback_profile(port: int | None = None, profile: str = "sim") -> Profile:
    """The named profile moved to `tcp/127.0.0.1:<port>` (a free port when None)."""
    port = port or free_tcp_port()
    return load_profile_file(profile).with_bus(endpoint=f"tcp/127.0.0.1:{port}")


class BusRouter:
    """An in-process Zenoh router on the profile's loopback endpoint (context manager)."""

    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.session: zenoh.Session | None = None

    def __enter__(self) -> zenoh.Session:
        if os.environ.get(ZENOH_RUNTIME_ENV) == ONE_WORKER_THREAD:
            # A one-worker router stalls the whole bus behind one slow subscriber
            # (services/runtime/zenoh_threads.py); tests must route as the real router does.
            raise RuntimeError(f"{ZENOH_RUNTIME_ENV} is the services' one-worker layout in this process: "
                               "a process that hosts a router keeps Zenoh's default threads")
        self.session = open_session(self.profile, "router", timeout_s=5.0)
        return self.session

    def __exit__(self, *exc: object) -> None:
        if self.session is not None:
            self.session.close()
            self.session = None


def interrupt_then_kill(proc: subprocess.Popen, timeout_s: float = 20.0) -> int:
    """Stop a process this test started (e.g. `handover-up`) as a user would: SIGINT, then
    SIGKILL if it has not exited after `timeout_s`. Returns its exit code."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.wait(5.0)


def kill_tree(proc: subprocess.Popen, wait_s: float = 10.0) -> None:
    """Kill a process this test started (e.g. `handover-up`) and whatever children it still
    has, by their PIDs (for a run that did not end by itself), and reap it (up to `wait_s`)."""
    import psutil

    try:
        children = psutil.Process(proc.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        children = []
    for child in children:
        try:
            child.kill()
        except psutil.NoSuchProcess:
            pass
    if proc.poll() is None:
        proc.kill()
    proc.wait(timeout=wait_s)


def run_launcher(args: list[str], timeout_s: float) -> tuple[int, str]:
    """Run ``python -m services.launcher ARGS`` (`handover-up`) to its end; (exit code, stdout and
    stderr as one text). A run still going after `timeout_s` is killed with its children and
    raises AssertionError with the end of its output."""
    import sys

    proc = subprocess.Popen([sys.executable, "-m", "services.launcher", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        kill_tree(proc)
        out, _ = proc.communicate()
        raise AssertionError(f"handover-up {' '.join(args)} did not exit in {timeout_s:.0f} s:\n"
                             f"{out[-6000:]}") from None
    return proc.returncode, out


def wait_until(predicate: Callable[[], bool], timeout_s: float, interval_s: float = 0.01) -> bool:
    """Poll `predicate` until it is true or `timeout_s` passes; return its last value."""
    deadline = time.monotonic() + timeout_s
    while True:
        if predicate():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(interval_s)


class ServiceProcess:
    """A service started as ``python -m <module>`` against `profile`'s endpoint.

    Output goes to a log file (``.log_text()`` reads it). Leaving the context sends SIGTERM,
    then SIGKILL after `term_timeout_s`, to this process only.
    """

    def __init__(self, module: str, profile: Profile, args: Sequence[str] = (),
                 name: str | None = None, env: dict[str, str] | None = None,
                 term_timeout_s: float = 5.0) -> None:
        self.module = module
        self.profile = profile
        self.args = list(args)
        self.name = name or module.rsplit(".", 1)[-1]
        self.env = env
        self.term_timeout_s = term_timeout_s
        self.proc: subprocess.Popen[bytes] | None = None
        self._log = tempfile.NamedTemporaryFile(prefix=f"{self.name}-", suffix=".log", delete=False)
        self.log_path = Path(self._log.name)

    @property
    def pid(self) -> int:
        assert self.proc is not None
        return self.proc.pid

    def start(self) -> ServiceProcess:
        cmd = [sys.executable, "-m", self.module]
        if self.profile.path is not None:
            cmd += ["--profile", str(self.profile.path)]
        cmd += ["--endpoint", self.profile.endpoint, "--prefix", self.profile.prefix, *self.args]
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        if self.env:
            env.update(self.env)
        self.proc = subprocess.Popen(cmd, stdout=self._log, stderr=subprocess.STDOUT, env=env)
        return self

    def __enter__(self) -> ServiceProcess:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def stop(self) -> int | None:
        """SIGTERM, wait, SIGKILL; returns the exit code."""
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGCONT)
                self.proc.send_signal(signal.SIGTERM)
                self.proc.wait(self.term_timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5.0)
        self._log.close()
        return self.proc.returncode

    def log_text(self) -> str:
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")


def wait_alive(session: zenoh.Session, profile: Profile, names: set[str], timeout_s: float = 15.0) -> None:
    """Wait until every service in `names` has its liveliness token up, or raise."""
    missing = set(names)

    def check() -> bool:
        nonlocal missing
        missing = names - alive_services(session, profile.prefix, timeout_s=0.2)
        return not missing

    if not wait_until(check, timeout_s, 0.05):
        raise TimeoutError(f"services not alive after {timeout_s} s: {sorted(missing)}")


def client_session(profile: Profile) -> zenoh.Session:
    """A test-side client session on the profile's bus (close it yourself)."""
    return open_session(profile, "client", timeout_s=5.0)


__all__ = [
    "BusRouter",
    "ServiceProcess",
    "client_session",
    "free_tcp_port",
    "loopback_profile",
    "wait_alive",
    "wait_until",
]
