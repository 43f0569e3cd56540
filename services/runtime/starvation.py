"""Why a service's heartbeat thread woke late (pure but for `/proc` reads).

The supervisor calls a service silent when its heartbeat (10 Hz on one host, sent from its own
thread) is 0.25 s old. A live process can fall that silent in several ways, and they need different fixes:

- **starved of CPU**: the thread was runnable but waited on the kernel's run queue (the
  machine is overloaded, or the process's niceness puts it behind busier ones);
- **the machine paused**: the virtual machine's CPUs were taken by its host (*steal* time in
  ``/proc/stat``): every process is late at once, none of them waiting or running;
- **starved of CPU through the GIL**: the main thread, which runs the service loop and most
  often holds Python's interpreter lock, waited for a CPU while this thread slept on the lock;
- **starved of the GIL by a computation**: another thread of the process ran (the process
  used CPU) while holding Python's interpreter lock;
- **blocked**: the thread neither waited for a CPU nor did its process run: another thread
  held the GIL across a blocking call (an import's disk reads), or the machine paused in a way
  the kernel did not count as steal.

Linux keeps, per thread, the time spent running and the time spent waiting on the run queue
(``/proc/thread-self/schedstat``: on-CPU ns, run-queue wait ns, time slices; the main thread's
in ``/proc/self/schedstat``) and machine-wide steal time (``/proc/stat``). Sampled at every
wake-up (`WakeSampler`, about 15 µs), they tell these apart; `late_wake_report` turns two
samples into the one line the service logs, so the next false "silent" names its cause.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

#: A heartbeat thread that wakes this much after it meant to is reported, s (one beat on one host), at
#: INFO: it explains a silence; whether the silence matters is the supervisor's to say (it
#: calls a critical service silent when its last heartbeat is 0.25 s old, and warns then).
LATE_WAKE_REPORT_S = 0.1

_SCHEDSTAT = Path("/proc/thread-self/schedstat")
#: The process's main thread (the thread-group leader): it runs the service loop and is the
#: thread most often holding the GIL.
_MAIN_SCHEDSTAT = Path("/proc/self/schedstat")
_STAT = Path("/proc/stat")
_CLOCK_TICKS_PER_S = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
_CPUS = os.cpu_count() or 1


@dataclass(frozen=True)
class WakeSample:
    """One wake-up of a thread.

    Attributes:
        monotonic_s: `time.monotonic()` at the wake-up, s.
        queue_wait_s: the thread's total run-queue wait so far, s (None where the kernel
            does not say).
        process_cpu_s: the process's CPU time so far (all threads, user + system), s.
        main_queue_wait_s: the process's main thread's total run-queue wait so far, s (None
            where the kernel does not say).
        steal_s: the machine's steal time so far, per CPU, s (time its virtual CPUs were
            taken by the host; None where the kernel does not say).
    """

    monotonic_s: float
    queue_wait_s: float | None
    process_cpu_s: float
    steal_s: float | None = None
    main_queue_wait_s: float | None = None


def parse_schedstat(text: str) -> float | None:
    """Run-queue wait, s, from a ``schedstat`` line (``<on-cpu ns> <wait ns> <slices>``);
    None when the line is not three integers."""
    fields = text.split()
    if len(fields) != 3 or not all(f.isdigit() for f in fields):
        return None
    return int(fields[1]) / 1e9


def parse_steal(first_line: str, ticks_per_s: float = _CLOCK_TICKS_PER_S, cpus: int = _CPUS) -> float | None:
    """Steal time per CPU, s, from the first line of ``/proc/stat``
    (``cpu user nice system idle iowait irq softirq steal …`` in clock ticks, all CPUs
    summed); None when the line is not that."""
    fields = first_line.split()
    if len(fields) < 9 or fields[0] != "cpu" or not fields[8].isdigit():
        return None
    return int(fields[8]) / ticks_per_s / max(1, cpus)


@dataclass(frozen=True)
class RawWake:
    """A `WakeSample` before parsing: `monotonic_s`, the process's CPU time (s) and the raw
    text of ``/proc/thread-self/schedstat``, ``/proc/stat`` (its start) and the main thread's
    ``schedstat`` (None where a file could not be read)."""

    monotonic_s: float
    schedstat: str | None
    process_cpu_s: float
    stat: str | None
    main_schedstat: str | None

    def parsed(self) -> WakeSample:
        return WakeSample(self.monotonic_s, None if self.schedstat is None else parse_schedstat(self.schedstat),
                          self.process_cpu_s,
                          None if self.stat is None else parse_steal(self.stat.split("\n", 1)[0]),
                          None if self.main_schedstat is None else parse_schedstat(self.main_schedstat))


class WakeSampler:
    """Takes `WakeSample`s of the thread that made it, cheaply enough for every heartbeat wake.

    The ``/proc`` files stay open and are re-read in place (``pread`` at offset 0: about 15 µs
    a sample, against about 90 µs for opening and closing them each time, which at 40 wakes a
    second in each of ten services was a few percent of a core). Make it in the thread to be
    sampled: ``/proc/thread-self`` names the thread that opens it. Close it when done (it is a
    context manager); a file that cannot be opened or read gives None for its figure.
    """

    def __init__(self, schedstat_path: Path = _SCHEDSTAT, stat_path: Path = _STAT,
                 main_schedstat_path: Path = _MAIN_SCHEDSTAT) -> None:
        self._schedstat_fd = self._open(schedstat_path)
        self._stat_fd = self._open(stat_path)
        self._main_schedstat_fd = self._open(main_schedstat_path)

    @staticmethod
    def _open(path: Path) -> int | None:
        try:
            return os.open(path, os.O_RDONLY | os.O_CLOEXEC)
        except OSError:
            return None

    def sample(self) -> WakeSample:
        """This thread's `WakeSample` now."""
        return self.raw().parsed()

    def raw(self) -> RawWake:
        """This thread's figures now, unparsed: the reads only (a heartbeat thread takes one
        at every wake and parses two only when the wake was late)."""
        schedstat = reread_text(self._schedstat_fd, 128)
        stat = reread_text(self._stat_fd, 512)
        main = reread_text(self._main_schedstat_fd, 128)
        t = os.times()
        return RawWake(time.monotonic(), schedstat, t.user + t.system, stat, main)

    def close(self) -> None:
        fds = (self._schedstat_fd, self._stat_fd, self._main_schedstat_fd)
        # cleared first: a failed close must not leave an fd number that a later close would reuse
        self._schedstat_fd = self._stat_fd = self._main_schedstat_fd = None
        for fd in fds:
            if fd is not None:
                os.close(fd)

    def __enter__(self) -> WakeSampler:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def reread_text(fd: int | None, size: int) -> str | None:
    """The first `size` bytes of the ``/proc`` file open as `fd`, read again from its start
    (``pread`` at 0: no open and close per reading); None when `fd` is None or unreadable."""
    if fd is None:
        return None
    try:
        return os.pread(fd, size, 0).decode("ascii", "replace")
    except OSError:
        return None


def sample_wake() -> WakeSample:
    """This thread's `WakeSample` now (one-off; a loop should keep a `WakeSampler`)."""
    with WakeSampler() as sampler:
        return sampler.sample()


def late_s(previous: WakeSample, now: WakeSample, expected_gap_s: float) -> float:
    """How much later than `expected_gap_s` after `previous` the thread woke at `now`, s."""
    return (now.monotonic_s - previous.monotonic_s) - expected_gap_s


def _delta(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None else max(0.0, b - a)


def late_wake_report(previous: WakeSample, now: WakeSample, expected_gap_s: float,
                     report_s: float = LATE_WAKE_REPORT_S) -> str | None:
    """One line saying why a thread that meant to wake `expected_gap_s` after `previous`
    woke at `now` late by more than `report_s`; None when it was not that late.

    The first of these that covers at least half of the lateness names the cause: the
    thread's run-queue wait (no CPU), the machine's steal time (the host paused the VM), the
    main thread's run-queue wait (the thread that most often holds the GIL was itself waiting
    for a CPU, so this one slept on the GIL), the process's CPU time (another thread computing
    with the GIL); else the thread was blocked."""
    late = late_s(previous, now, expected_gap_s)
    if late <= report_s:
        return None
    cpu_s = max(0.0, now.process_cpu_s - previous.process_cpu_s)
    queued_s = _delta(previous.queue_wait_s, now.queue_wait_s)
    stolen_s = _delta(previous.steal_s, now.steal_s)
    main_queued_s = _delta(previous.main_queue_wait_s, now.main_queue_wait_s)
    parts = [f"heartbeat thread woke {1000.0 * late:.0f} ms late:"]
    parts.append("run-queue wait unknown," if queued_s is None else f"{1000.0 * queued_s:.0f} ms waiting for a CPU,")
    if stolen_s is not None:
        parts.append(f"{1000.0 * stolen_s:.0f} ms stolen by the host,")
    if main_queued_s is not None:
        parts.append(f"main thread {1000.0 * main_queued_s:.0f} ms waiting for a CPU,")
    parts.append(f"process used {1000.0 * cpu_s:.0f} ms of CPU meanwhile;")
    if queued_s is not None and queued_s >= 0.5 * late:
        cause = "starved of CPU: the machine is overloaded or this process's niceness is too high"
    elif stolen_s is not None and stolen_s >= 0.5 * late:
        cause = "the machine paused: the host took its virtual CPUs (steal time)"
    elif main_queued_s is not None and main_queued_s >= 0.5 * late:
        cause = ("starved of CPU through the GIL: the main thread, which most often holds it, was waiting for a "
                 "CPU (the machine is overloaded)")
    elif cpu_s >= 0.5 * late:
        cause = "held up inside its own process: another thread computed holding the GIL"
    elif queued_s is None:
        cause = "cause unknown (no run-queue figures on this kernel)"
    else:
        cause = ("blocked: neither waiting for a CPU nor running (the GIL held across a blocking call, "
                 "or a pause of the whole machine)")
    return " ".join(parts) + " " + cause
