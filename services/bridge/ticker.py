"""The bridge's loop clock: a fixed-rate grid (100 Hz) plus an immediate tick when a stop
arrives.

`RateLoop` (services.runtime) sleeps until the next deadline whatever arrives meanwhile, so
a `motion/stop` waited up to one period (10 ms) for the bridge to act on it. `StopTicker`
sleeps in `ServiceNode.wait` instead: every subscription's callback wakes it, and when
`urgent()` says an unhandled stop is queued it yields an extra tick at once (the caller
computes the real elapsed dt). The grid is kept: extra ticks do not move the next deadline.
At most one extra tick runs per period: the first stop engages the brake; a flood of stops
cannot turn the loop into a busy loop (later ones are handled on the grid, ≤ one period).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from services.runtime import RateLimitedLog
from services.runtime.loop import OVERRUN_LOG_PERIOD_S, skip_missed

log = logging.getLogger(__name__)


@dataclass
class TickerStats:
    """Counters of a `StopTicker`.

    Attributes:
        ticks: grid ticks run so far.
        urgent_ticks: extra ticks run because `urgent()` was true.
        wakeups: returns from the wait before the deadline (any message wakes it).
        overruns: grid ticks whose work ran past the next deadline.
        skipped: grid deadlines skipped to catch up after an overrun.
        worst_lateness_s: largest lateness of a grid tick's start, s.
    """

    ticks: int = 0
    urgent_ticks: int = 0
    wakeups: int = 0
    overruns: int = 0
    skipped: int = 0
    worst_lateness_s: float = 0.0


class StopTicker:
    """Iterate at `rate_hz` until the node stops; yields False on a grid tick and True on an
    urgent extra tick.

    Args:
        node: the open `ServiceNode` (its `wait`, woken by every subscription, and
            `should_stop`).
        rate_hz: grid rate, Hz (> 0).
        urgent: called after each wake-up; True runs an extra tick at once (at most one per
            period). None: never (the grid only, like `RateLoop`).
        name: for the overrun log line.
    """

    def __init__(self, node: Any, rate_hz: float, urgent: Callable[[], bool] | None,
                 name: str = "loop") -> None:
        if not rate_hz > 0:
            raise ValueError(f"loop rate must be > 0 Hz, got {rate_hz}")
        self.node = node
        self.period_s = 1.0 / rate_hz
        self.urgent = urgent
        self.name = name
        self.stats = TickerStats()
        self._overrun_log = RateLimitedLog(log, OVERRUN_LOG_PERIOD_S)

    def __iter__(self) -> Iterator[bool]:
        period = self.period_s
        node = self.node
        next_deadline = time.monotonic()
        while not node.should_stop:
            lateness = time.monotonic() - next_deadline
            self.stats.worst_lateness_s = max(self.stats.worst_lateness_s, lateness)
            yield False
            self.stats.ticks += 1
            next_deadline += period
            now = time.monotonic()
            if now > next_deadline:
                next_deadline = skip_missed(self.stats, self._overrun_log, self.name, period, next_deadline, now)
                continue
            extra_allowed = True
            while not node.should_stop:
                remaining = next_deadline - time.monotonic()
                if remaining <= 0.0:
                    break
                if self.urgent is None or not extra_allowed:
                    node.stop_event.wait(remaining)
                    continue
                node.wait(remaining)
                if node.should_stop:
                    return
                if time.monotonic() < next_deadline:
                    self.stats.wakeups += 1
                if self.urgent():
                    self.stats.urgent_ticks += 1
                    extra_allowed = False
                    yield True
