"""What the launcher's monitor thread sleeps on: a child's exit, a liveliness change or a stop.

The monitor used to look at its children and their liveliness 50 times a second, idle or not
(issue 16: 0.007 core of the idle stack, a thread wake every 20 ms). Now it sleeps until one
of them happens: a child's process file descriptor becomes readable when the child exits
(`services.runtime.exits.ExitWatch`), and a liveliness change or a stop request writes to an
eventfd. A time-out of `BACKSTOP_S` covers a child the kernel gave no process file
descriptor for (its liveliness token still wakes the monitor when it dies).
"""

from __future__ import annotations

import os
import threading

from services.runtime.exits import ExitWatch

#: The monitor looks at least this often whatever happened, s.
BACKSTOP_S = 1.0


class MonitorWakeup:
    """Children's exits and explicit wake-ups for one sleeping thread (Linux: eventfd)."""

    def __init__(self) -> None:
        self.exits = ExitWatch()
        self._fd = os.eventfd(0, os.EFD_CLOEXEC | os.EFD_NONBLOCK)
        self._lock = threading.Lock()  # `watch`/`forget` come from the main and the monitor thread

    def wake(self) -> None:
        """End the current or the next `wait` at once (any thread, a signal handler too)."""
        try:
            os.eventfd_write(self._fd, 1)
        except OSError:  # closed at shutdown: nobody waits any more
            pass

    def watch(self, name: str, pid: int) -> None:
        """Wake the monitor when child `name` (process `pid`) exits."""
        with self._lock:
            self.exits.watch(name, pid)

    def forget(self, name: str) -> None:
        """Stop watching child `name` (its exit was handled)."""
        with self._lock:
            self.exits.forget(name)

    def wait(self, timeout_s: float = BACKSTOP_S) -> set[str]:
        """Sleep until a watched child exits, `wake` is called or `timeout_s` (s) passes; the
        watched children that have exited."""
        return self.exits.wait(timeout_s, self._fd)

    def close(self) -> None:
        with self._lock:
            self.exits.close()
        os.close(self._fd)


class WakingEvent(threading.Event):
    """A `threading.Event` whose `set` also wakes a `MonitorWakeup` (the launcher's stop request)."""

    def __init__(self, wakeup: MonitorWakeup) -> None:
        super().__init__()
        self._wakeup = wakeup

    def set(self) -> None:
        super().set()
        self._wakeup.wake()
