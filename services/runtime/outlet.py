"""Line output that never blocks its callers: a bounded queue and one writer thread.

A control or safety loop must never wait on a log write, a pipe or a terminal (a pipe nobody
reads, a terminal paused with Ctrl-S). `LineOutlet.put(line)` only appends to a bounded queue;
one daemon thread writes the queue to a file descriptor with `os.write` (no Python buffer object,
so no lock a caller could wait on). When the queue is full the oldest waiting line is dropped and
counted, never waited for; once the descriptor takes output again the writer says how many lines
were dropped, then writes the newest ones. A descriptor that its opener made non-blocking is
waited for in the writer thread like a blocking one (a full pipe is not a broken one).

The services' logging (`services.runtime.logs`) and the launcher's relay of its children's
output (`services.launcher.processes`) both write through one.
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections import deque

#: Default queue bound, in lines.
DEFAULT_MAX_LINES = 4096
#: Most bytes the writer joins into one `os.write`.
_BATCH_BYTES = 64 * 1024
#: Longest single wait of the writer for a full non-blocking descriptor, s (then it retries).
_WRITABLE_WAIT_S = 1.0


def _wait_writable(fd: int) -> None:
    """Wait (in the writer thread) until `fd` takes output, fails or `_WRITABLE_WAIT_S` passes;
    the next write then says which."""
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    poller.poll(_WRITABLE_WAIT_S * 1000)


class LineOutlet:
    """Writes whole lines to file descriptor `fd` from its own thread.

    When `max_lines` are waiting, the OLDEST waiting line is dropped for each new one (the
    newest output, a failure's reason, is what a reader needs most when the output resumes).

    Attributes:
        dropped: lines dropped so far (queue full, or the descriptor failed).
        written: lines written so far.
    """

    def __init__(self, fd: int, max_lines: int = DEFAULT_MAX_LINES, name: str = "output",
                 drop_notice: str = "{n} output line(s) dropped while the output was blocked\n") -> None:
        self.fd = fd
        self.name = name
        self.dropped = 0
        self.written = 0
        self._reported = 0
        self._drop_notice = drop_notice
        self._lines: deque[bytes] = deque()
        self._max_lines = max_lines
        self._cond = threading.Condition()  # guards the deque and the counters; never held during I/O
        self._busy = False
        self._broken = False
        self._thread = threading.Thread(target=self._run, name=f"{name} writer", daemon=True)
        self._thread.start()

    def put(self, line: str) -> bool:
        """Queue one line (with its newline) for writing; never blocks on I/O.

        Returns:
            False when the output is broken and the line was dropped; True when it was queued
            (an older line may have been dropped to make room).
        """
        data = line.encode(errors="replace")
        with self._cond:
            if self._broken:
                self.dropped += 1
                return False
            if len(self._lines) >= self._max_lines:
                self._lines.popleft()
                self.dropped += 1
            self._lines.append(data)
            self._cond.notify()
        return True

    def flush(self, timeout_s: float = 1.0) -> bool:
        """Wait up to `timeout_s` for the queue to be written (at exit, never in a loop).

        Returns:
            True when everything queued so far was written.
        """
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._lines or self._busy:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self._broken:
                    return False
                self._cond.wait(remaining)
        return True

    def close(self, timeout_s: float = 1.0) -> bool:
        """Write what waits (up to `timeout_s`), then take no more lines (`put` drops and counts
        them) and close the descriptor.

        Returns:
            True when everything was written and the descriptor closed; False when the writer
            was still in a write at the time-out (the descriptor is then left open: closing it
            under the writer could hand its number to another file).
        """
        self.flush(timeout_s)
        with self._cond:
            self._broken = True
            self._cond.notify_all()
            if self._busy or self._lines:
                return False
        os.close(self.fd)
        return True

    def _take(self) -> list[bytes]:
        with self._cond:
            while not self._lines:
                self._busy = False
                self._cond.notify_all()
                self._cond.wait()
            self._busy = True
            batch, size = [], 0
            while self._lines and size < _BATCH_BYTES:
                batch.append(self._lines.popleft())
                size += len(batch[-1])
            return batch

    def _run(self) -> None:
        while True:
            batch = self._take()
            ok = self._write(b"".join(batch))
            with self._cond:
                if ok:
                    self.written += len(batch)
                else:
                    self.dropped += len(batch)
                notice_n, total = self.dropped - self._reported, self.dropped
                self._reported = self.dropped
            if ok and notice_n > 0:
                self._write(self._drop_notice.format(n=notice_n, total=total).encode())

    def _write(self, data: bytes) -> bool:
        if self._broken:
            return False
        view = memoryview(data)
        while view:
            try:
                n = os.write(self.fd, view)
            except InterruptedError:
                continue
            except BlockingIOError:  # a non-blocking descriptor (O_NONBLOCK set by whoever opened it) is full
                _wait_writable(self.fd)
                continue
            except OSError:  # closed pipe, bad descriptor: drop from now on, never raise
                with self._cond:
                    self._broken = True
                    self._cond.notify_all()
                return False
            view = view[n:]
        return True
