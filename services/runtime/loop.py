"""The one loop-pacing primitive of the services: `RateLoop`, a fixed-rate deadline grid with
overrun reporting and, optionally, an urgent extra tick between grid ticks.

Time and sleeping are injected (a monotonic-seconds callable and a wait(timeout_s) callable,
by default `time.monotonic` and the stop event's `wait`), so a loop can be driven by another
clock than the local one.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass

from services.runtime.clock import first_grid_time_s
from services.runtime.logs import RateLimitedLog

log = logging.getLogger(__name__)

#: A loop's overruns are logged at most once per this many seconds (each line counts them all).
OVERRUN_LOG_PERIOD_S = 10.0

#: wait(timeout_s): blocks at most `timeout_s` seconds; returns early on a stop (and, for a
#: wake source, when something arrived). Its return value is not used.
WaitFn = Callable[[float], object]


@dataclass
class LoopStats:
    """Counters of a `RateLoop`.

    Attributes:
        ticks: grid ticks run so far.
        urgent_ticks: extra ticks run between grid ticks because `urgent()` was true.
        wakeups: returns of the wake source before the deadline (with `urgent` only).
        overruns: grid ticks whose work ran past the next deadline.
        skipped: deadlines skipped to catch up after an overrun.
        worst_lateness_s: largest lateness of a grid tick's start, s.
    """

    ticks: int = 0
    urgent_ticks: int = 0
    wakeups: int = 0
    overruns: int = 0
    skipped: int = 0
    worst_lateness_s: float = 0.0


class RateLoop:
    """Iterate at `rate_hz` on a deadline grid until `stop_event` is set; each iteration yields
    the tick index (ticks run before it, grid and urgent).

    Between ticks the loop sleeps with `wait`, which a shutdown request ends at once. When a
    tick's work overruns the period the loop does not try to catch up with a burst: it skips the
    missed deadlines, counts them and logs at most once every `OVERRUN_LOG_PERIOD_S`.

    With `urgent` the loop sleeps in `wake_source` instead, which returns early when something
    arrives (`ServiceNode.wait`: any subscription declared with ``wake=True``). After each
    early return it asks `urgent()`; when True it runs an extra tick at once (`urgent_tick` is
    True during it; the caller measures the real elapsed time). Extra ticks do not move the grid,
    and at most one runs per period: the first urgent event is acted on at once, a flood of them
    cannot turn the loop into a busy loop (later ones are handled on the grid, within a period).

    Args:
        rate_hz: grid rate, Hz (> 0).
        stop_event: ends the loop once set.
        name: for the overrun log line.
        clock: monotonic time, s (default `time.monotonic`).
        wait: wait(timeout_s) until the next deadline or a stop (default ``stop_event.wait``).
        urgent: called after each early wake; True runs an extra tick. None: the grid only.
        wake_source: wait(timeout_s) that also returns when something arrives; required with
            `urgent`.
        urgent_per_period: most urgent ticks between two grid ticks (default 1); None: every
            early wake that `urgent()` accepts runs one (a loop that must act on each message,
            as the supervisor's release interrupt does).
        align_phase_s: None (the wall clock): the first tick runs at once. A phase (s): the
            grid is ``align_phase_s + k · period`` from time 0 and the first tick waits for
            its first point (the simulation clock, where every run must tick at the same times).
        tolerance_s: a deadline counts as reached this close before it, s (the simulation
            clock's whole-ns times against the grid's float sums).
        rest_on_grid: a `rest_until` deadline is moved to the grid point nearest to it (with
            `align_phase_s`), so that a resting loop still wakes with the others of the host.

    Attributes:
        period_s: the grid's period, s; a tick may change it (the supervisor ticks slower
            once its last episode ended), the next deadline follows the new period.
        stats: the loop's `LoopStats`.
        urgent_tick: the tick just yielded is an urgent extra tick.
    """

    def __init__(self, rate_hz: float, stop_event: threading.Event, name: str = "loop", *,
                 clock: Callable[[], float] = time.monotonic, wait: WaitFn | None = None,
                 urgent: Callable[[], bool] | None = None, wake_source: WaitFn | None = None,
                 urgent_per_period: int | None = 1, align_phase_s: float | None = None,
                 tolerance_s: float = 0.0, rest_on_grid: bool = False) -> None:
        if not rate_hz > 0:
            raise ValueError(f"loop rate must be > 0 Hz, got {rate_hz}")
        if urgent is not None and wake_source is None:
            raise ValueError("an urgent tick needs a wake source that returns when something arrives")
        self.period_s = 1.0 / rate_hz
        self.stop_event = stop_event
        self.name = name
        self.stats = LoopStats()
        self.urgent_tick = False
        self._clock = clock
        self._wait: WaitFn = wait if wait is not None else stop_event.wait
        self._urgent = urgent
        self._urgent_per_period = urgent_per_period
        self._rest_until_s: float | None = None
        self._wake_source = wake_source
        self._align_phase_s = align_phase_s
        self._tolerance_s = tolerance_s
        self._rest_on_grid = rest_on_grid and align_phase_s is not None
        self._overrun_log = RateLimitedLog(log, OVERRUN_LOG_PERIOD_S)

    def rest_until(self, deadline_s: float) -> None:
        """Hold the next grid tick back until `deadline_s` (monotonic s) at the earliest: a
        loop with nothing to do (motion holding still) ticks only when it next must. Asked for
        again in each tick that should rest. An urgent tick still runs at once, and ends the
        rest unless that tick asks for it again; the grid then continues from the later of
        the two deadlines."""
        self._rest_until_s = deadline_s

    def __iter__(self) -> Iterator[int]:
        stats = self.stats
        next_deadline = self._clock()
        if self._align_phase_s is not None:
            next_deadline = first_grid_time_s(next_deadline, self.period_s, self._align_phase_s)
            next_deadline = yield from self._sleep_until(next_deadline)
        while not self.stop_event.is_set():
            lateness = self._clock() - next_deadline
            if lateness > stats.worst_lateness_s:
                stats.worst_lateness_s = lateness
            self.urgent_tick = False
            self._rest_until_s = None
            yield stats.ticks + stats.urgent_ticks
            stats.ticks += 1
            next_deadline += self.period_s
            if self._align_phase_s is not None:  # k · period from the phase, not a sum that drifts
                phase = self._align_phase_s
                next_deadline = phase + round((next_deadline - phase) / self.period_s) * self.period_s
            now = self._clock()
            if now > next_deadline + self._tolerance_s:
                next_deadline = self._skip_missed(next_deadline, now)
                continue
            next_deadline = yield from self._sleep_until(next_deadline)

    def _take_rest(self, grid_deadline_s: float) -> float | None:
        """The rest deadline the last tick asked for (not before `grid_deadline_s`), or None."""
        rest, self._rest_until_s = self._rest_until_s, None
        if rest is not None and self._rest_on_grid:
            assert self._align_phase_s is not None
            rest = first_grid_time_s(rest - self.period_s / 2, self.period_s, self._align_phase_s)
        return None if rest is None else max(grid_deadline_s, rest)

    def _sleep_until(self, grid_deadline_s: float) -> Generator[int, None, float]:
        """Sleep until the grid deadline (or the rest deadline) or a stop; yields an urgent extra
        tick's index at most once. Returns the deadline slept to: the next grid tick's."""
        rest = self._take_rest(grid_deadline_s)
        extra_left = 0 if self._urgent is None else self._urgent_per_period
        while not self.stop_event.is_set():
            deadline_s = grid_deadline_s if rest is None else rest
            remaining = deadline_s - self._clock()
            if remaining <= self._tolerance_s:
                break
            if extra_left == 0:
                self._wait(remaining)
                continue
            assert self._wake_source is not None and self._urgent is not None
            self._wake_source(remaining)
            if self.stop_event.is_set():
                break
            if self._clock() >= deadline_s - self._tolerance_s:
                break  # the deadline came: the grid tick takes whatever arrived
            self.stats.wakeups += 1
            if self._urgent():
                extra_left = None if extra_left is None else extra_left - 1
                index = self.stats.ticks + self.stats.urgent_ticks
                self.stats.urgent_ticks += 1
                self.urgent_tick = True
                yield index
                was_resting, rest = rest is not None, self._take_rest(grid_deadline_s)
                if was_resting and rest is None:  # the rest is over: back to the grid's next deadline
                    grid_deadline_s = self._first_grid_deadline_after(grid_deadline_s, self._clock())
        return grid_deadline_s if rest is None else rest

    def _first_grid_deadline_after(self, deadline_s: float, now_s: float) -> float:
        """The first deadline of the grid through `deadline_s` that is later than `now_s` (s)."""
        if now_s < deadline_s:
            return deadline_s
        return deadline_s + (int((now_s - deadline_s) // self.period_s) + 1) * self.period_s

    def _skip_missed(self, next_deadline_s: float, now_s: float) -> float:
        """A tick's work ran past `next_deadline_s` (monotonic s): count the overrun and the
        deadlines skipped, log it (rate-limited) and return the deadline to wait for next: the
        last missed one, so the loop does not burst to catch up."""
        period = self.period_s
        missed = int((now_s - next_deadline_s) // period) + 1
        self.stats.overruns += 1
        self.stats.skipped += missed - 1
        next_deadline_s += (missed - 1) * period
        self._overrun_log.info("overrun", f"{self.name} tick overran its {period * 1e3:.1f} ms period",
                               overruns=self.stats.overruns,
                               late_ms=round((now_s - next_deadline_s + period) * 1e3, 2))
        return next_deadline_s
