"""Why a service's heartbeat thread woke late: no CPU, or no GIL (pure but for `/proc` reads).

The supervisor calls a service silent when its heartbeat (20 Hz, sent from its own thread) is
0.25 s old. A live process can fall that silent in two ways, and they need different fixes:

- **starved of CPU**: the thread was runnable but waited on the kernel's run queue (the
  machine is overloaded, or the process's niceness puts it behind busier ones);
- **starved of the GIL**: the thread was not on the run queue but waited for Python's
  interpreter lock while another thread of the process held it (a long computation, or a
  blocking call such as an import's disk reads).

Linux keeps, per thread, the time spent running and the time spent waiting on the run queue
(``/proc/thread-self/schedstat``: on-CPU ns, run-queue wait ns, time slices). Sampled at every
wake-up, the run-queue wait over a late gap tells the two apart; `late_wake_report` turns the
samples into the one line the service logs, so the next false "silent" names its cause.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

#: A heartbeat thread that wakes this much after it meant to is reported, s (two beats).
LATE_WAKE_REPORT_S = 0.1
#: ... and reported as a warning from this lateness on, s (the supervisor calls a critical
#: service silent when its last heartbeat is 0.25 s old).
LATE_WAKE_WARNING_S = 0.2

_SCHEDSTAT = Path("/proc/thread-self/schedstat")


@dataclass(frozen=True)
class WakeSample:
    """One wake-up of a thread.

    Attributes:
        monotonic_s: `time.monotonic()` at the wake-up, s.
        queue_wait_s: the thread's total run-queue wait so far, s (None where the kernel
            does not say).
        process_cpu_s: the process's CPU time so far (all threads, user + system), s.
    """

    monotonic_s: float
    queue_wait_s: float | None
    process_cpu_s: float


def parse_schedstat(text: str) -> float | None:
    """Run-queue wait, s, from a ``schedstat`` line (``<on-cpu ns> <wait ns> <slices>``);
    None when the line is not three integers."""
    fields = text.split()
    if len(fields) != 3 or not all(f.isdigit() for f in fields):
        return None
    return int(fields[1]) / 1e9


def sample_wake() -> WakeSample:
    """This thread's `WakeSample` now."""
    try:
        queue_wait_s = parse_schedstat(_SCHEDSTAT.read_text())
    except OSError:
        queue_wait_s = None
    t = os.times()
    return WakeSample(time.monotonic(), queue_wait_s, t.user + t.system)


def late_s(previous: WakeSample, now: WakeSample, expected_gap_s: float) -> float:
    """How much later than `expected_gap_s` after `previous` the thread woke at `now`, s."""
    return (now.monotonic_s - previous.monotonic_s) - expected_gap_s


def late_wake_report(previous: WakeSample, now: WakeSample, expected_gap_s: float,
                     report_s: float = LATE_WAKE_REPORT_S) -> str | None:
    """One line saying why a thread that meant to wake `expected_gap_s` after `previous`
    woke at `now` late by more than `report_s`; None when it was not that late.

    Of the time the thread was late, the part it spent on the run queue is CPU starvation;
    the rest it was runnable-and-running or waiting for a lock, which for a Python thread
    that only sleeps and sends is the GIL."""
    late = late_s(previous, now, expected_gap_s)
    if late <= report_s:
        return None
    cpu_ms = 1000.0 * max(0.0, now.process_cpu_s - previous.process_cpu_s)
    head = f"heartbeat thread woke {1000.0 * late:.0f} ms late"
    if previous.queue_wait_s is None or now.queue_wait_s is None:
        return f"{head} (process used {cpu_ms:.0f} ms of CPU meanwhile; run-queue wait unknown)"
    queued_s = max(0.0, now.queue_wait_s - previous.queue_wait_s)
    if queued_s >= 0.5 * late:
        cause = "starved of CPU: the machine is overloaded or this process's niceness is too high"
    else:
        cause = "held up inside its own process (another thread held the GIL: a long computation or a blocking call)"
    return (f"{head}: {1000.0 * queued_s:.0f} ms waiting for a CPU, process used {cpu_ms:.0f} ms of CPU "
            f"meanwhile; {cause}")
