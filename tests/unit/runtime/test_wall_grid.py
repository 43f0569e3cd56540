"""Every wall-clock loop of the stack ticks on one grid of the host's monotonic clock
(`WALL_GRID_PHASE_S`), so the loops of all the processes wake together; a resting loop's
deadline is moved onto that grid too. Fake clocks for the grid arithmetic; real sessions on a
loopback router (the suite's `bus`) for the services' loops and heartbeats."""

from __future__ import annotations

import threading
import time

import pytest

from bus_schema import decoder_for, topics
from services.runtime.clock import WALL_GRID_PHASE_S, seconds_to_wall_grid
from services.runtime.loop import RateLoop
from services.runtime.node import ServiceNode
from services.runtime.testing import wait_until


class _FakeTime:
    """A monotonic clock that a wait moves on (no real sleeping)."""

    def __init__(self, start_s: float) -> None:
        self.now_s = start_s
        self.waits: list[float] = []

    def clock(self) -> float:
        return self.now_s

    def wait(self, timeout_s: float) -> None:
        self.waits.append(timeout_s)
        self.now_s += timeout_s


def _ticks(loop: RateLoop, fake: _FakeTime, count: int, rest_s: float | None = None) -> list[float]:
    """The fake times of the first `count` ticks; each asks to rest `rest_s` past its start."""
    times = []
    for _ in loop:
        times.append(fake.now_s)
        if len(times) == count:
            loop.stop_event.set()
        elif rest_s is not None:
            loop.rest_until(fake.now_s + 0.0004 + rest_s)  # the tick's work took 0.4 ms
    return times


def _late_s(time_s: float, period_s: float) -> float:
    """How long after the last point k · period_s `time_s` is (s)."""
    return (time_s - WALL_GRID_PHASE_S) % period_s


def _off_grid_s(time_s: float, period_s: float) -> float:
    """Distance of `time_s` from the nearest point k · period_s (s)."""
    phase = (time_s - WALL_GRID_PHASE_S) % period_s
    return min(phase, period_s - phase)


def test_an_aligned_loop_ticks_on_the_grid_from_any_start():
    fake = _FakeTime(1234.5678)
    loop = RateLoop(100.0, threading.Event(), clock=fake.clock, wait=fake.wait, align_phase_s=WALL_GRID_PHASE_S)
    times = _ticks(loop, fake, 5)
    assert times[0] == pytest.approx(1234.57, abs=1e-9)  # waits for the grid: no tick at once
    assert all(_off_grid_s(t, 0.01) < 1e-9 for t in times)


def test_a_resting_loop_wakes_on_the_grid_point_nearest_its_rest_deadline():
    fake = _FakeTime(100.0)
    loop = RateLoop(100.0, threading.Event(), clock=fake.clock, wait=fake.wait,
                    align_phase_s=WALL_GRID_PHASE_S, rest_on_grid=True)
    times = _ticks(loop, fake, 4, rest_s=0.05)
    gaps = [b - a for a, b in zip(times, times[1:])]
    assert gaps == pytest.approx([0.05] * 3, abs=1e-9)  # 50 ms, not 50.4 ms then the next 10 ms point
    assert all(_off_grid_s(t, 0.01) < 1e-9 for t in times)


def test_without_rest_on_grid_the_rest_deadline_is_kept_as_asked():
    fake = _FakeTime(100.0)
    loop = RateLoop(100.0, threading.Event(), clock=fake.clock, wait=fake.wait, align_phase_s=WALL_GRID_PHASE_S)
    times = _ticks(loop, fake, 3, rest_s=0.05)
    assert times[1] - times[0] == pytest.approx(0.0504, abs=1e-9)


def test_seconds_to_wall_grid_reaches_the_next_point_and_never_zero():
    assert seconds_to_wall_grid(0.02, now_s=10.005) == pytest.approx(0.015)
    assert seconds_to_wall_grid(0.02, now_s=10.0) == pytest.approx(0.02)  # on a point: the next one
    assert seconds_to_wall_grid(0.02, now_s=10.0199) == pytest.approx(0.0201)  # never a busy 0.1 ms
    assert 0.002 <= seconds_to_wall_grid(0.02) <= 0.022


def test_a_service_loop_and_its_heartbeats_are_on_the_host_grid(bus):
    profile, router = bus
    beat_times: list[float] = []
    decode_beat = decoder_for(topics.HEARTBEAT.type)

    wall_minus_monotonic_s = time.time() - time.monotonic()

    def on_beat(sample) -> None:  # when the beat was sent, on the monotonic clock
        beat_times.append(decode_beat.decode(sample.payload.to_bytes()).stamp_ns * 1e-9 - wall_minus_monotonic_s)

    sub = router.declare_subscriber(topics.HEARTBEAT.sender_key("grid-probe", profile.prefix), on_beat)
    try:
        with ServiceNode("grid-probe", profile, install_signal_handlers=False) as node:
            period_s = 0.05
            tick_times = []
            for _ in node.loop(1.0 / period_s):
                tick_times.append(time.monotonic())
                if len(tick_times) == 10:
                    break
            assert wait_until(lambda: len(beat_times) >= 12, 5.0)
    finally:
        sub.undeclare()
    # A tick or a beat is never before its grid point, only late (a busy machine: several ms).
    # The smallest lateness: one prompt wake is enough, where a loop on its own phase sits at
    # one fixed place of its period (anywhere in 50 ms for the loop, 100 ms for the beats).
    assert min(_late_s(t, period_s) for t in tick_times) < 0.003
    assert min(_late_s(t, node.heartbeat_period_s) for t in beat_times) < 0.005
