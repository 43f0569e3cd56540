"""RateLoop timing bookkeeping and the rate-limited log."""

from __future__ import annotations

import logging
import threading
import time

import pytest

from services.runtime.logs import RateLimitedLog
from services.runtime.loop import RateLoop


def test_loop_ends_on_stop_event_and_counts_ticks():
    stop = threading.Event()
    loop = RateLoop(200.0, stop)
    seen = []
    for tick in loop:
        seen.append(tick)
        if tick == 9:
            stop.set()
    assert seen == list(range(10))
    assert loop.stats.ticks == 10


def test_loop_paces_at_its_rate():
    stop = threading.Event()
    loop = RateLoop(100.0, stop)
    t0 = time.monotonic()
    for tick in loop:
        if tick == 20:
            stop.set()
    elapsed = time.monotonic() - t0
    assert elapsed >= 0.19  # 20 periods of 10 ms must have passed (never faster than the rate)


def test_overruns_are_counted_and_deadlines_skipped():
    stop = threading.Event()
    loop = RateLoop(100.0, stop)
    for tick in loop:
        if tick == 0:
            time.sleep(0.035)  # miss about three deadlines
        if tick == 2:
            stop.set()
    assert loop.stats.overruns >= 1
    assert loop.stats.skipped >= 2


def test_an_overrun_skips_the_missed_deadlines_on_an_injected_clock():
    now = [10.0]
    stop = threading.Event()

    def wait(timeout_s: float) -> bool:
        now[0] += timeout_s
        return stop.is_set()

    loop = RateLoop(100.0, stop, clock=lambda: now[0], wait=wait)
    starts = []
    for tick in loop:
        starts.append(now[0])
        if tick == 1:
            now[0] += 0.035  # the work of tick 1 misses the deadlines at 10.02, 10.03 and 10.04
        if tick == 4:
            stop.set()
    # Tick 2 at once (no burst after it), then back on the grid.
    assert starts == pytest.approx([10.0, 10.01, 10.045, 10.05, 10.06])
    assert (loop.stats.overruns, loop.stats.skipped) == (1, 2)
    assert loop.stats.worst_lateness_s == pytest.approx(0.005)


def test_a_30_hz_frame_loop_keeps_the_rate_and_does_not_burst_after_a_late_frame():
    # The simulated Kinect's frame thread (`services.sim_kinect.thread`): frames take 12 ms,
    # the second one 0.18 s.
    now = [100.0]
    stop = threading.Event()
    waits: list[float] = []

    def wait(timeout_s: float) -> bool:
        waits.append(timeout_s)
        now[0] += timeout_s
        return stop.is_set()

    loop = RateLoop(30.0, stop, clock=lambda: now[0], wait=wait)
    starts = []
    for frame in loop:
        starts.append(now[0])
        now[0] += 0.18 if frame == 1 else 0.012
        if frame == 3:
            stop.set()
    # Frame 1 ends at 100.2133, past five deadlines: frame 2 at once with no wait (not five
    # frames in a burst), then frame 3 on the 30 Hz grid again (100 + 7/30 s).
    assert starts == pytest.approx([100.0, 100.0 + 1 / 30, 100.0 + 1 / 30 + 0.18, 100.0 + 7 / 30])
    assert waits == pytest.approx([1 / 30 - 0.012, 7 / 30 - (1 / 30 + 0.18 + 0.012)])  # none after the stop
    assert (loop.stats.ticks, loop.stats.overruns, loop.stats.skipped) == (4, 1, 4)


def test_rate_must_be_positive():
    with pytest.raises(ValueError):
        RateLoop(0.0, threading.Event())


def test_rate_limited_log_counts_everything_logs_once_per_period(caplog):
    limiter = RateLimitedLog(logging.getLogger("t"), period_s=60.0)
    with caplog.at_level(logging.WARNING):
        for _ in range(100):
            limiter.warning("bad", "bad payload")
        limiter.warning("other", "other problem")
    assert limiter.counts == {"bad": 100, "other": 1}
    assert [r.getMessage() for r in caplog.records] == ["bad payload", "other problem"]
