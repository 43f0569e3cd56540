"""What the launcher's monitor thread sleeps on: a child's exit, a liveliness change or a stop.

The monitor used to look at its children and their liveliness 50 times a second, idle or not
(issue 16: 0.007 core of the idle stack, a thread wake every 20 ms). Now it sleeps until one
of them happens: a child's process file descriptor becomes readable when the child exits
(`services.runtime.exits.ExitWatch`), and a liveliness change or a stop request writes to an
eventfd. A child the kernel gave no process file descriptor for (an old kernel, a sandbox
without ``pidfd_open``) is looked at every `UNWATCHED_POLL_S`, as before; otherwise a time-out
of `BACKSTOP_S` is the only wake with nothing to do.
"""

from __future__ import annotations

import os
import threading

from services.runtime.exits import ExitWatch

#: The monitor looks at least this often whatever happened, s.
BACKSTOP_S = 1.0
#: ... and this often while a child has no process file descriptor (an old kernel, a
#: sandbox that forbids ``pidfd_open``): the old loop's period, s.
UNWATCHED_POLL_S = 0.02


class MonitorWakeup:
    """Children's exits and explicit wake-ups for one sleeping thread (Linux: eventfd).

    `watch` and `forget` are called by the thread that waits (and by others only before it
    starts); `wake` by any thread or a signal handler. After `close`, `wake` does nothing and
    `wait` returns at once."""

    def __init__(self) -> None:
        self.exits = ExitWatch()
        self._fd = os.eventfd(0, os.EFD_CLOEXEC | os.EFD_NONBLOCK)
        self._closed = False
        self._unwatched: set[str] = set()  # children the kernel gave no process file descriptor for

    def wake(self) -> None:
        """End the current or the next `wait` at once (any thread, a signal handler too)."""
        if self._closed:
            return
        try:
            os.eventfd_write(self._fd, 1)
        except OSError:  # closed meanwhile: nobody waits any more
            pass

    def watch(self, name: str, pid: int) -> None:
        """Wake the monitor when child `name` (process `pid`) exits (where the kernel cannot
        tell, `wait` sleeps at most `UNWATCHED_POLL_S` while that child is watched)."""
        if self.exits.watch(name, pid):
            self._unwatched.discard(name)
        else:
            self._unwatched.add(name)

    def forget(self, name: str) -> None:
        """Stop watching child `name` (its exit was handled)."""
        self.exits.forget(name)
        self._unwatched.discard(name)

    def exited(self) -> set[str]:
        """The watched children that have exited (no waiting)."""
        return self.exits.exited()

    def wait(self, timeout_s: float | None = None) -> set[str]:
        """Sleep until a watched child exits, `wake` is called or `timeout_s` (s; default
        `BACKSTOP_S`) passes (`UNWATCHED_POLL_S` while a child is not watched); the watched
        children that have exited."""
        if self._closed:
            return set()
        timeout_s = BACKSTOP_S if timeout_s is None else timeout_s
        return self.exits.wait(min(timeout_s, UNWATCHED_POLL_S) if self._unwatched else timeout_s, self._fd)

    def close(self) -> None:
        """Close the eventfd and every process file descriptor (once; later calls do nothing)."""
        if self._closed:
            return
        self._closed = True
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
