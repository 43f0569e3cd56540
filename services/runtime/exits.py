"""Has a service's process ended? Asked of the kernel, not of the bus (one host).

A killed service is normally seen through its liveliness token: the router notices the closed
socket and tells every watcher. On a machine short of CPU that takes as long as the router and
the watcher wait for a CPU (146 ms once, beside two busy loops). The kernel knows at once: a
process file descriptor (``pidfd_open``, Linux ≥ 5.3) becomes readable the moment its process
exits. `ExitWatch` holds one per watched service and answers, with one non-blocking ``poll``,
which of them have ended.
"""

from __future__ import annotations

import os
import select


class ExitWatch:
    """Process exits of watched services (see the module docstring).

    Where ``pidfd_open`` is not available (another OS, an old kernel, a process that is
    already gone) a service is simply not watched: its liveliness token still tells.
    """

    def __init__(self) -> None:
        self._fds: dict[str, tuple[int, int]] = {}  # service -> (pid, fd)
        self._poll = select.poll() if hasattr(select, "poll") else None
        self._wake_fds: set[int] = set()  # registered by `wait`

    def watch(self, service: str, pid: int) -> bool:
        """Watch `service` as process `pid` (replacing an earlier pid of that service); False
        when the kernel gives no process file descriptor for it (not watched)."""
        old = self._fds.get(service)
        if old is not None and old[0] == pid:
            return True
        self.forget(service)
        if self._poll is None or not hasattr(os, "pidfd_open"):
            return False
        try:
            fd = os.pidfd_open(pid)
        except OSError:  # gone already, or not allowed: liveliness will tell
            return False
        self._fds[service] = (pid, fd)
        self._poll.register(fd, select.POLLIN)
        return True

    def forget(self, service: str) -> None:
        """Stop watching `service`."""
        old = self._fds.pop(service, None)
        if old is not None and self._poll is not None:
            self._poll.unregister(old[1])
            os.close(old[1])

    def exited(self) -> set[str]:
        """The watched services whose process has ended (one non-blocking ``poll``)."""
        if not self._fds or self._poll is None:
            return set()
        ready = {fd for fd, _events in self._poll.poll(0)}
        return {service for service, (_pid, fd) in self._fds.items() if fd in ready}

    def wait(self, timeout_s: float, wake_fd: int) -> set[str]:
        """Block until a watched process ends, `wake_fd` (an eventfd or a pipe's read end)
        becomes readable, or `timeout_s` (s) passes; returns `exited()`. A readable `wake_fd`
        is read to clear it. A process that ended stays in the answer (and makes this return
        at once) until it is forgotten."""
        if self._poll is None:
            select.select([wake_fd], [], [], timeout_s)
        else:
            if wake_fd not in self._wake_fds:
                self._poll.register(wake_fd, select.POLLIN)
                self._wake_fds.add(wake_fd)
            self._poll.poll(max(0, round(timeout_s * 1000)))
        try:
            os.read(wake_fd, 8)
        except OSError:  # not woken (a process ended, or the time-out), or closed meanwhile
            pass
        return self.exited()

    def close(self) -> None:
        for service in list(self._fds):
            self.forget(service)
