"""Fixed-rate loop with overrun reporting, driven by the local monotonic clock."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from services.runtime.logs import RateLimitedLog

log = logging.getLogger(__name__)

#: A loop's overruns are logged at most once per this many seconds (each line counts them all).
OVERRUN_LOG_PERIOD_S = 10.0


@dataclass
class LoopStats:
    """Counters of a `RateLoop`.

    Attributes:
        ticks: ticks run so far.
        overruns: ticks whose work ran past the next deadline.
        skipped: deadlines skipped to catch up after an overrun.
        worst_lateness_s: largest lateness of a tick start, s.
    """

    ticks: int = 0
    overruns: int = 0
    skipped: int = 0
    worst_lateness_s: float = 0.0


def skip_missed(stats: Any, overrun_log: RateLimitedLog, name: str, period_s: float,
                next_deadline_s: float, now_s: float) -> float:
    """A tick's work ran past `next_deadline_s` (monotonic s): count the overrun and the
    deadlines skipped (`stats.overruns`, `stats.skipped`), log it (rate-limited) and return the
    deadline to wait for next: the last missed one, so the loop does not burst to catch up."""
    missed = int((now_s - next_deadline_s) // period_s) + 1
    stats.overruns += 1
    stats.skipped += missed - 1
    next_deadline_s += (missed - 1) * period_s
    overrun_log.info("overrun", f"{name} tick overran its {period_s * 1e3:.1f} ms period",
                     overruns=stats.overruns, late_ms=round((now_s - next_deadline_s + period_s) * 1e3, 2))
    return next_deadline_s


class RateLoop:
    """Iterate at `rate_hz` until `stop_event` is set.

    Each iteration yields the tick index. Sleeping uses ``stop_event.wait`` so a shutdown
    request ends the loop at once. When a tick's work overruns the period the loop does not
    try to catch up with a burst: it skips the missed deadlines, counts them and logs at most
    once every `OVERRUN_LOG_PERIOD_S`.
    """

    def __init__(self, rate_hz: float, stop_event: threading.Event, name: str = "loop") -> None:
        if not rate_hz > 0:
            raise ValueError(f"loop rate must be > 0 Hz, got {rate_hz}")
        self.period_s = 1.0 / rate_hz
        self.stop_event = stop_event
        self.name = name
        self.stats = LoopStats()
        self._overrun_log = RateLimitedLog(log, OVERRUN_LOG_PERIOD_S)

    def __iter__(self) -> Iterator[int]:
        period = self.period_s
        next_deadline = time.monotonic()
        while not self.stop_event.is_set():
            now = time.monotonic()
            lateness = now - next_deadline
            if lateness > self.stats.worst_lateness_s:
                self.stats.worst_lateness_s = lateness
            yield self.stats.ticks
            self.stats.ticks += 1
            next_deadline += period
            now = time.monotonic()
            if now > next_deadline:
                next_deadline = skip_missed(self.stats, self._overrun_log, self.name, period, next_deadline, now)
                continue
            self.stop_event.wait(next_deadline - now)
