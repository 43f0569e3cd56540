"""Child processes of `handover-up`: start, prefix output, signal, reap.

Children run in their own process group (so a terminal's Ctrl-C reaches only the launcher,
which then shuts them down in order) and get SIGTERM from the kernel if the launcher dies
(Linux `PR_SET_PDEATHSIG`), so no service outlives its launcher. A child can be started at a
higher niceness (lower CPU priority) than the launcher's, set before `exec` so that even its
imports run at that priority; raising niceness needs no privilege.

Output never blocks: each child's pipe is read by its own thread, which queues every line
for the child's log file (`services.launcher.logfiles`) and the lines the console shows (all
with ``--verbose``; else warnings, errors and lines that are no log record) for stdout, through
one bounded `LineOutlet` per destination. When stdout does not take output (a pipe nobody
reads, a terminal paused with Ctrl-S) lines are dropped and counted, and the launcher says how
many once stdout takes output again; neither a child nor the launcher's own watch ever waits
for it.
"""

from __future__ import annotations

import ctypes
import functools
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence

from services.launcher.core import prefix_line, shown_when_quiet
from services.runtime.outlet import LineOutlet

_PR_SET_PDEATHSIG = 1
#: Lines that may wait for a blocked stdout before the oldest are dropped (profile key
#: ``[launcher] output_queue_lines``); a whole handover run prints about a hundred.
DEFAULT_OUTPUT_QUEUE_LINES = 8192
_outlet: LineOutlet | None = None
_outlet_lock = threading.Lock()


#: Thread pools of numerical libraries, off in every service: their arrays are small, and
#: an idle pool costs more than it saves. OpenCV's workers poll with ``sched_yield`` after
#: each parallel call (measured in the idle tracker: ~300 wakes a second) and OpenBLAS keeps
#: a worker per core; with one thread each, a call runs in the caller's thread.
SINGLE_THREADED_LIBRARIES = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENCV_FOR_THREADS_NUM": "1"}


def stdout_outlet(max_lines: int = DEFAULT_OUTPUT_QUEUE_LINES) -> LineOutlet:
    """The launcher's non-blocking stdout, made on first use with room for `max_lines` waiting
    lines (`max_lines` of a later call is ignored: call it first where the bound matters).

    Once made it is returned without taking a lock: the launcher's signal handler says what it
    does, and a handler that waited for a lock its own thread held would hang the launcher."""
    global _outlet
    outlet = _outlet
    if outlet is not None:
        return outlet
    with _outlet_lock:
        if _outlet is None:
            _outlet = LineOutlet(sys.stdout.fileno(), max_lines=max_lines, name="stdout",
                                 drop_notice="[launcher] {n} output line(s) dropped while stdout was "
                                             "blocked ({total} in all)\n")
        return _outlet


def emit(line: str) -> None:
    """Queue one whole line for the launcher's stdout; never blocks (dropped and counted when
    stdout is blocked and the queue is full)."""
    stdout_outlet().put(line)


def relay(name: str, line: str, width: int, log: LineOutlet | None, verbose: bool) -> None:
    """One output line of child `name`: to its log file, and to the console prefixed ``[name]``
    when `verbose` or `shown_when_quiet`; never blocks."""
    if log is not None:
        log.put(line if line.endswith("\n") else line + "\n")
    if verbose or shown_when_quiet(line):
        emit(prefix_line(name, line, width))


def _child_setup(nice: int = 0) -> None:  # runs in the child between fork and exec
    os.setpgid(0, 0)
    increment = nice - os.nice(0)
    if increment > 0:  # never below the launcher's own niceness: lowering needs privileges
        os.nice(increment)
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except OSError:
        pass


class Child:
    """One service process: its output to `log` (its file) and, prefixed ``[name]``, to the
    launcher's stdout (every line when `verbose`, else what `shown_when_quiet` keeps)."""

    def __init__(self, name: str, command: Sequence[str], name_width: int,
                 env: dict[str, str] | None = None, nice: int = 0, log: LineOutlet | None = None,
                 verbose: bool = True) -> None:
        """`nice`: the child's niceness, 0..19 (at least the launcher's own)."""
        self.name = name
        self.log = log
        self.verbose = verbose
        self.command = list(command)
        self.name_width = name_width
        self.env = env
        self.nice = nice
        self.proc: subprocess.Popen[bytes] | None = None
        self.started_monotonic = 0.0
        self._reader: threading.Thread | None = None

    def start(self) -> None:
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        for key, value in SINGLE_THREADED_LIBRARIES.items():
            env.setdefault(key, value)  # a user's own value stays
        if self.env:
            env.update(self.env)
        self.proc = subprocess.Popen(
            self.command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            env=env, preexec_fn=functools.partial(_child_setup, self.nice),
        )
        self.started_monotonic = time.monotonic()
        self._reader = threading.Thread(target=self._pump, name=f"out-{self.name}", daemon=True)
        self._reader.start()

    def _pump(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for raw in iter(self.proc.stdout.readline, b""):
            relay(self.name, raw.decode(errors="replace"), self.name_width, self.log, self.verbose)

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc else None

    def poll(self) -> int | None:
        return None if self.proc is None else self.proc.poll()

    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def signal(self, sig: int) -> None:
        if self.running():
            assert self.proc is not None
            try:
                self.proc.send_signal(sig)
            except ProcessLookupError:
                pass

    def wait(self, timeout_s: float) -> int | None:
        if self.proc is None:
            return None
        try:
            return self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            return None

    def stop(self, term_timeout_s: float) -> tuple[int | None, str]:
        """SIGINT; SIGTERM after `term_timeout_s`; SIGKILL after `term_timeout_s` more.

        Returns:
            (exit code, which signal ended it).
        """
        if not self.running():
            self._join_reader()
            return self.poll(), "already exited"
        self.signal(signal.SIGCONT)  # a stopped (frozen) child cannot act on SIGINT
        for sig in (signal.SIGINT, signal.SIGTERM):
            self.signal(sig)
            code = self.wait(term_timeout_s)
            if code is not None:
                self._join_reader()
                return code, signal.Signals(sig).name
        self.signal(signal.SIGKILL)
        code = self.wait(5.0)
        self._join_reader()
        return code, "SIGKILL"

    def _join_reader(self) -> None:
        if self._reader is not None:
            self._reader.join(timeout=1.0)


class RouterProcess:
    """The stack's Zenoh router in its own process (`services.launcher.router`).

    Its stdout and stderr are one pipe, read by a thread for as long as the router runs: the
    ``ready`` line, then anything it says (to `log` and, as a child's, to the console `relay`
    keeps, ``[router]``-prefixed, never blocking), so the router (the bus itself) never waits on
    a full pipe.
    """

    def __init__(self, config_json: str, name_width: int = len("router"), log: LineOutlet | None = None,
                 verbose: bool = True) -> None:
        self.config_json = config_json
        self.log = log
        self.verbose = verbose
        self.name_width = name_width
        self.proc: subprocess.Popen[bytes] | None = None
        self._answered = threading.Event()  # the ready line came, or the output ended
        self._ready = False
        self._said: list[str] = []  # lines before the ready line (the reason it did not start)
        self._reader: threading.Thread | None = None

    def start(self, timeout_s: float = 10.0) -> None:
        """Start the router and wait until it listens.

        Raises:
            RuntimeError: it did not come up; the message is the router's own reason.
        """
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "services.launcher.router"], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, preexec_fn=_child_setup,
        )
        assert self.proc.stdin is not None
        self._reader = threading.Thread(target=self._read, name="out-router", daemon=True)
        self._reader.start()
        self.proc.stdin.write(self.config_json.encode())
        self.proc.stdin.close()
        if not self._answered.wait(timeout_s) or not self._ready:
            self.stop(1.0)
            self._reader.join(1.0)
            raise RuntimeError(self._reason() or f"the router did not answer within {timeout_s:.0f} s")

    def _reason(self) -> str:
        """The router's own error (its last ``router: …`` message, which may span lines)."""
        said = [line for line in self._said if line]
        starts = [i for i, line in enumerate(said) if line.startswith("router: ")]
        return " ".join(said[starts[-1]:]) if starts else (said[-1] if said else "")

    def _read(self) -> None:
        from services.launcher.router import READY

        assert self.proc is not None and self.proc.stdout is not None
        for raw in iter(self.proc.stdout.readline, b""):
            line = raw.decode(errors="replace")
            if self._ready:
                relay("router", line, self.name_width, self.log, self.verbose)
            elif line.startswith(READY):
                self._ready = True
                self._answered.set()
            else:
                self._said.append(line.strip())
        self._answered.set()

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc else None

    def stop(self, timeout_s: float = 5.0) -> int | None:
        """SIGTERM, then SIGKILL after `timeout_s`; returns the exit code."""
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                return self.proc.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        return self.proc.wait()
