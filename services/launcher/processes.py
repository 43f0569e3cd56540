"""Child processes of `handover-up`: start, prefix output, signal, reap.

Children run in their own process group (so a terminal's Ctrl-C reaches only the launcher,
which then shuts them down in order) and get SIGTERM from the kernel if the launcher dies
(Linux `PR_SET_PDEATHSIG`), so no service outlives its launcher. A child can be started at a
higher niceness (lower CPU priority) than the launcher's, set before `exec` so that even its
imports run at that priority; raising niceness needs no privilege.
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
from typing import TextIO

from services.launcher.core import prefix_line

_PR_SET_PDEATHSIG = 1
_print_lock = threading.Lock()


def emit(line: str, stream: TextIO | None = None) -> None:
    """Write one whole line to the launcher's output without interleaving."""
    out = stream or sys.stdout
    with _print_lock:
        out.write(line)
        out.flush()


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
    """One service process with its output prefixed ``[name]`` on the launcher's stdout."""

    def __init__(self, name: str, command: Sequence[str], name_width: int,
                 env: dict[str, str] | None = None, nice: int = 0) -> None:
        """`nice`: the child's niceness, 0..19 (at least the launcher's own)."""
        self.name = name
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
            emit(prefix_line(self.name, raw.decode(errors="replace"), self.name_width))

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
