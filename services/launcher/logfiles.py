"""The run's log files: every line of every service, of the router and of the launcher itself,
one file each in a folder beside the recording (`services.launcher.core.logs_dir`).

`handover-up` is quiet on the console by default (its own progress, the services' warnings
and errors, the summary); the files hold everything, and ``--verbose`` relays every line to
the console as well.

A file is written like the console: through its own bounded `LineOutlet`, whose thread does
the `os.write`. The thread that reads a child's pipe only queues the line, so a slow or full
disk holds back neither a service nor the launcher's watch: when a file does not take output,
its oldest waiting lines are dropped and counted, and the count is written into that file once
it takes output again.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from services.runtime.outlet import LineOutlet

#: Lines that may wait for one log file before the oldest are dropped.
DEFAULT_FILE_QUEUE_LINES = 8192
LAUNCHER = "launcher"
_launcher_file: LineOutlet | None = None  # read without a lock: `own_line` runs in a signal handler too


def stamp(now_s: float | None = None) -> str:
    """``HH:MM:SS.mmm``, local time, as a service's log line starts."""
    now_s = time.time() if now_s is None else now_s
    return time.strftime("%H:%M:%S", time.localtime(now_s)) + f".{int(now_s * 1000) % 1000:03d}"


def own_line(text: str, level: str = "INFO") -> None:
    """Queue one of the launcher's own lines for ``launcher.log``, stamped and levelled like a
    service's log line; never blocks (nothing happens before the files are open)."""
    outlet = _launcher_file
    if outlet is not None:
        outlet.put(f"{stamp()} {level:<7} {text}\n")


class LogFiles:
    """The log folder of one run and a non-blocking outlet per file (module docstring).

    Attributes:
        directory: the folder (made by `open`).
        error: why the folder or a file could not be opened (None while all is well).
    """

    def __init__(self, directory: Path, max_lines: int = DEFAULT_FILE_QUEUE_LINES) -> None:
        self.directory = directory
        self.max_lines = max_lines
        self.error: str | None = None
        self._outlets: dict[str, LineOutlet] = {}
        self._lock = threading.Lock()

    def open(self) -> bool:
        """Make the folder and ``launcher.log`` (the launcher's own lines go there from now on).

        Returns:
            False when that failed (`error` says why; the caller shows the output instead).
        """
        global _launcher_file
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self.error = f"cannot make {self.directory}: {exc.strerror or exc}"
            return False
        _launcher_file = self.outlet(LAUNCHER)
        return _launcher_file is not None

    def path(self, name: str) -> Path:
        return self.directory / f"{name}.log"

    def outlet(self, name: str) -> LineOutlet | None:
        """The outlet of ``<name>.log``, opened (emptied) on first use and then kept: a restarted
        service goes on in the same file. None when the file cannot be opened (`error`)."""
        with self._lock:
            if name in self._outlets:
                return self._outlets[name]
            try:
                fd = os.open(self.path(name), os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND | os.O_CLOEXEC,
                             0o644)
            except OSError as exc:
                self.error = f"cannot write {self.path(name)}: {exc.strerror or exc}"
                return None
            outlet = LineOutlet(fd, max_lines=self.max_lines, name=f"{name}.log",
                                drop_notice=f"{{n}} line(s) of {name} dropped: this file did not take "
                                            "them ({total} in all)\n")
            self._outlets[name] = outlet
            return outlet

    def close(self, timeout_s: float = 2.0) -> bool:
        """Wait up to `timeout_s` in all for the waiting lines to be written, then close the files
        (`LineOutlet.close`: later lines are dropped; a file whose writer is still stuck stays
        open until the process exits).

        Returns:
            True when every line was written and every file closed.
        """
        global _launcher_file
        deadline = time.monotonic() + timeout_s
        with self._lock:
            outlets, self._outlets = list(self._outlets.values()), {}
        if any(outlet is _launcher_file for outlet in outlets):
            _launcher_file = None
        done = True
        for outlet in outlets:
            done = outlet.close(max(0.0, deadline - time.monotonic())) and done
        return done
