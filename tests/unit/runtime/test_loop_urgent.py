"""`RateLoop` with an urgent predicate (the bridge's loop: a stop runs a tick at once): one
extra tick between grid ticks, the grid kept, at most one extra tick per period; on fake time."""

from __future__ import annotations

import pytest

from services.runtime.loop import RateLoop


class FakeClock:
    """`time.monotonic` for the loop, advanced only by the fake node's waits, s."""

    def __init__(self) -> None:
        self.now_s = 100.0

    def monotonic(self) -> float:
        return self.now_s


class FakeStopEvent:
    """`threading.Event` whose `wait` lets fake time pass instead of real time."""

    def __init__(self, clock: FakeClock) -> None:
        self.clock = clock
        self._set = False

    def set(self) -> None:
        self._set = True

    def is_set(self) -> bool:
        return self._set

    def wait(self, timeout_s: float) -> bool:
        self.clock.now_s += max(0.0, timeout_s)
        return self._set


class ScriptedNode:
    """The part of `ServiceNode` the loop uses, on fake time: `wait` returns at once when a
    message is queued (`notify`), else at the first scripted message within the time-out
    (time, is_stop), else when the time-out passes. No threads, no real sleeps: the test
    does not depend on how busy the machine is."""

    def __init__(self, clock: FakeClock, script: list[tuple[float, bool]] = ()) -> None:
        self.clock = clock
        self.stop_event = FakeStopEvent(clock)
        self.script = sorted(script)
        self.stop_pending = False
        self._new = False

    @property
    def should_stop(self) -> bool:
        return self.stop_event.is_set()

    def notify(self) -> None:
        self._new = True

    def wait(self, timeout_s: float) -> bool:
        if not self._new and self.script and self.script[0][0] <= self.clock.now_s + timeout_s:
            at_s, is_stop = self.script.pop(0)
            self.clock.now_s = max(self.clock.now_s, at_s)
            self.stop_pending |= is_stop
            self._new = True
        elif not self._new:
            self.clock.now_s += max(0.0, timeout_s)
        got, self._new = self._new, False
        return got


@pytest.fixture
def clock():
    return FakeClock()


def _urgent_loop(node: ScriptedNode, clock: FakeClock, rate_hz: float, urgent) -> RateLoop:
    """A `RateLoop` on the scripted node's fake time, as `ServiceNode.rate_loop` builds it."""
    return RateLoop(rate_hz, node.stop_event, clock=clock.monotonic, urgent=urgent,
                    wake_source=node.wait if urgent is not None else None)


def _run(loop: RateLoop, node: ScriptedNode, clock: FakeClock, grid_ticks: int) -> list[tuple[bool, float]]:
    """Iterate `loop` for `grid_ticks` grid ticks; returns (urgent, fake time) per tick. An
    urgent tick drains the pending stop, as the bridge's does."""
    ticks: list[tuple[bool, float]] = []
    for _tick in loop:
        urgent = loop.urgent_tick
        ticks.append((urgent, clock.now_s))
        if urgent:
            node.stop_pending = False
        elif sum(not u for u, _ in ticks) >= grid_ticks:
            node.stop_event.set()
    return ticks


@pytest.mark.parametrize("also_unrelated", [False, True])
def test_a_stop_runs_one_extra_tick_between_grid_ticks(clock, also_unrelated):
    # 50 Hz grid from t = 100 s; the stop arrives 5 ms after the third grid tick (and, before
    # it, optionally a message that wakes the loop but is not urgent, e.g. a joint command).
    script = [(100.045, True)] + ([(100.043, False)] if also_unrelated else [])
    node = ScriptedNode(clock, script)
    loop = _urgent_loop(node, clock, 50.0, lambda: node.stop_pending)
    ticks = _run(loop, node, clock, grid_ticks=6)
    assert [u for u, _ in ticks] == [False, False, False, True, False, False, False]
    assert ticks[3][1] == pytest.approx(100.045)  # at once, not at the next grid tick
    assert loop.stats.urgent_ticks == 1 and loop.stats.ticks == 6
    # The grid is kept: the extra tick did not move the following grid ticks.
    assert [t for u, t in ticks if not u] == pytest.approx([100.0 + 0.02 * k for k in range(6)])


def test_a_flood_of_stops_runs_at_most_one_extra_tick_per_period(clock):
    node = ScriptedNode(clock)
    loop = _urgent_loop(node, clock, 50.0, lambda: True)  # a stop is always pending
    kinds = []
    for _tick in loop:
        kinds.append(loop.urgent_tick)
        node.notify()  # and another one arrives at once
        if kinds.count(False) >= 4:
            node.stop_event.set()
    assert kinds == [False, True, False, True, False, True, False]


def test_without_urgent_the_stop_waits_for_the_grid(clock):
    node = ScriptedNode(clock, [(100.025, True)])
    loop = _urgent_loop(node, clock, 50.0, None)
    ticks = _run(loop, node, clock, grid_ticks=5)
    assert all(not u for u, _ in ticks) and loop.stats.urgent_ticks == 0
    assert [t for _u, t in ticks] == pytest.approx([100.0 + 0.02 * k for k in range(5)])
    assert node.script == [(100.025, True)]  # it never woke the loop: it sleeps to the next grid tick


def test_tick_indexes_count_grid_and_urgent_ticks(clock):
    node = ScriptedNode(clock, [(100.005, True)])
    loop = _urgent_loop(node, clock, 50.0, lambda: node.stop_pending)
    seen = []
    for tick in loop:
        seen.append((tick, loop.urgent_tick))
        node.stop_pending = False
        if len(seen) == 3:
            node.stop_event.set()
    assert seen == [(0, False), (1, True), (2, False)]
    assert (loop.stats.ticks, loop.stats.urgent_ticks, loop.stats.wakeups) == (2, 1, 1)


def test_an_urgent_predicate_needs_a_wake_source(clock):
    node = ScriptedNode(clock)
    with pytest.raises(ValueError, match="wake source"):
        RateLoop(50.0, node.stop_event, urgent=lambda: True)


def test_a_resting_loop_ticks_only_when_its_rest_ends(clock):
    # 100 Hz grid; every tick asks to rest 50 ms (motion holding still): ticks 50 ms apart,
    # no overrun counted for the grid deadlines it rested over.
    node = ScriptedNode(clock)
    loop = _urgent_loop(node, clock, 100.0, lambda: False)
    times = []
    for _tick in loop:
        times.append(clock.now_s)
        loop.rest_until(clock.now_s + 0.05)
        if len(times) == 4:
            node.stop_event.set()
    assert times == pytest.approx([100.0, 100.05, 100.10, 100.15])
    assert loop.stats.overruns == 0 and loop.stats.skipped == 0


def test_an_urgent_tick_ends_the_rest_and_the_grid_resumes_without_an_overrun(clock):
    # Resting from t = 100 s until 100.05 s; a goal arrives at 100.032 s: an extra tick at
    # once, which does not rest again (the arm moves): the next grid ticks follow at 100 Hz
    # from the first grid deadline after it (100.04, 100.05, ...), with no overrun.
    node = ScriptedNode(clock, [(100.032, True)])
    loop = _urgent_loop(node, clock, 100.0, lambda: node.stop_pending)
    ticks = []
    for _tick in loop:
        ticks.append((loop.urgent_tick, clock.now_s))
        if loop.urgent_tick:
            node.stop_pending = False
        elif len(ticks) == 1:
            loop.rest_until(clock.now_s + 0.05)
        if len(ticks) == 5:
            node.stop_event.set()
    assert ticks == [(False, pytest.approx(100.0)), (True, pytest.approx(100.032)),
                     (False, pytest.approx(100.04)), (False, pytest.approx(100.05)),
                     (False, pytest.approx(100.06))]
    assert loop.stats.overruns == 0


def test_an_urgent_tick_that_rests_again_keeps_resting(clock):
    # A stop while holding still: the extra tick runs and asks to rest again.
    node = ScriptedNode(clock, [(100.02, True)])
    loop = _urgent_loop(node, clock, 100.0, lambda: node.stop_pending)
    ticks = []
    for _tick in loop:
        ticks.append((loop.urgent_tick, clock.now_s))
        node.stop_pending = False
        loop.rest_until(clock.now_s + 0.05)
        if len(ticks) == 3:
            node.stop_event.set()
    assert ticks == [(False, pytest.approx(100.0)), (True, pytest.approx(100.02)),
                     (False, pytest.approx(100.07))]


def test_without_a_limit_every_wake_runs_an_extra_tick(clock):
    # The supervisor's loop: a release, then a heartbeat 2 ms later, both within one 10 ms
    # period: each is acted on at once, and the grid is kept.
    node = ScriptedNode(clock, [(100.003, True), (100.005, True)])
    loop = RateLoop(100.0, node.stop_event, clock=clock.monotonic, urgent=lambda: True,
                    wake_source=node.wait, urgent_per_period=None)
    ticks = []
    for _tick in loop:
        ticks.append((loop.urgent_tick, clock.now_s))
        if len(ticks) == 4:
            node.stop_event.set()
    assert ticks == [(False, pytest.approx(100.0)), (True, pytest.approx(100.003)),
                     (True, pytest.approx(100.005)), (False, pytest.approx(100.01))]


def test_a_tick_may_change_the_period(clock):
    node = ScriptedNode(clock)
    loop = _urgent_loop(node, clock, 100.0, None)
    times = []
    for _tick in loop:
        times.append(clock.now_s)
        if len(times) == 2:
            loop.period_s = 0.025  # the supervisor once its last episode has ended
        if len(times) == 4:
            node.stop_event.set()
    assert times == pytest.approx([100.0, 100.01, 100.035, 100.06])
