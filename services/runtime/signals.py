"""SIGINT/SIGTERM acted on in a thread of their own: the signal handler takes no lock.

Python runs a signal handler in the main thread, between two of its bytecodes, wherever that
thread happens to be: inside `threading.Event.wait`, for instance, holding the event's lock for
the few bytecodes around the sleep. A handler that calls `Event.set()` there (or notifies a
condition, or logs through a lock) waits for a lock its own thread holds, and the process hangs
on its stop signal. CI met it once: the recorder logged "received SIGINT, shutting down" and
never stopped, and the launcher waited the 60 s it gives a recorder to finalise.

`SignalRelay` keeps the handler lock-free: it writes the signal's number into a non-blocking
pipe (`os.write`, no Python lock) and returns; a daemon thread reads the pipe and calls
``on_signal(signum)``, an ordinary thread that may take any lock, log and set events.
"""

from __future__ import annotations

import logging
import os
import signal
import threading
from collections.abc import Callable, Iterable
from typing import Any

log = logging.getLogger(__name__)

#: The signals a service stops on.
STOP_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)


class SignalRelay:
    """While installed, `signals` call ``on_signal(signum)`` from the relay's thread.

    Install and restore from the main thread (Python's rule for `signal.signal`); elsewhere
    `install` does nothing and returns False. `restore` puts back the handlers that were
    there before and ends the thread; both are idempotent.
    """

    def __init__(self, on_signal: Callable[[int], None], signals: Iterable[int] = STOP_SIGNALS,
                 name: str = "signals") -> None:
        self.on_signal = on_signal
        self.signals = tuple(signals)
        self.name = name
        self._previous: dict[int, Any] = {}
        self._write_fd: int | None = None
        self._thread: threading.Thread | None = None

    @property
    def installed(self) -> bool:
        return self._write_fd is not None

    def install(self) -> bool:
        """Take over `signals` (main thread only); True if installed."""
        if self.installed or threading.current_thread() is not threading.main_thread():
            return self.installed
        read_fd, self._write_fd = os.pipe2(os.O_CLOEXEC)
        os.set_blocking(self._write_fd, False)  # a full pipe drops the signal, never blocks the handler
        self._thread = threading.Thread(target=self._relay, args=(read_fd,), name=self.name, daemon=True)
        self._thread.start()
        for sig in self.signals:
            self._previous[sig] = signal.signal(sig, self._handler)
        return True

    def _handler(self, signum: int, _frame: object) -> None:
        """The signal handler itself: one `os.write`, no lock, no allocation worth a name."""
        write_fd = self._write_fd
        if write_fd is None:
            return
        try:
            os.write(write_fd, bytes((signum,)))
        except OSError:  # full (hundreds of signals unread) or closed: the ones already queued will do
            pass

    def _relay(self, read_fd: int) -> None:
        """The relay thread: reads signal numbers until `restore` closes the write end, then
        closes its read end itself. A failing `on_signal` is logged; the next signal still
        comes through."""
        try:
            while True:
                try:
                    data = os.read(read_fd, 64)
                except InterruptedError:
                    continue
                except OSError:
                    return
                if not data:  # the write end closed: `restore`
                    return
                for signum in data:
                    try:
                        self.on_signal(signum)
                    except Exception:  # noqa: BLE001 - a stop signal must never go unheard after one error
                        log.exception("%s: acting on signal %d failed", self.name, signum)
        finally:
            os.close(read_fd)

    def restore(self, join_timeout_s: float = 1.0) -> None:
        """Put the previous handlers back (main thread only) and end the relay thread."""
        if not self.installed or threading.current_thread() is not threading.main_thread():
            return
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()
        write_fd, self._write_fd = self._write_fd, None
        assert write_fd is not None
        os.close(write_fd)  # the relay reads what is left, then end of file, and closes its end
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(join_timeout_s)
