"""Release interrupt with the whole stack: a release event while the arm moves stops it.

3 episodes of `handover-up --job none --receiver absent`; in each, a `gripper/release` is
published during the reach while the arm moves (see `release_interrupt`). Asserted: the
supervisor reacts (its `motion/stop` and its ``released`` state follow the event) and the
arm comes to rest, each time, within a generous 0.5 s (the issue's 50 ms p99 is measured by
tests/bench/test_bench_release_interrupt.py on 32 runs; on a shared, overloaded CI machine
the supervisor's reaction alone reached 0.27 s, so timing is not asserted tightly). A stack
ended early by a watchdog protective stop (a starved service) is replaced by another one.
"""

from __future__ import annotations

import pytest

from tests.faults.release_interrupt import MOVING_RAD_S, measure_release_interrupts

pytestmark = [pytest.mark.integration, pytest.mark.timeout(240)]

GENEROUS_BOUND_S = 0.5


def test_a_release_during_the_reach_stops_the_moving_arm():
    samples: list = []
    stops: list[str] = []
    for stack in range(3):
        if len(samples) >= 3:
            break
        samples += measure_release_interrupts(3 - len(samples), seed=2 + stack, protective_stops_out=stops)
    assert len(samples) >= 3, (samples, stops)
    for s in samples:
        assert s.speed_at_release_rad_s >= MOVING_RAD_S  # the arm was moving
        assert s.event_to_stop_s is not None and s.event_to_released_state_s is not None, s
        assert s.event_to_rest_s is not None, s
        # Timing and order by the senders' stamps where recorded: this test process may itself
        # be starved, which delays and reorders what it receives from different senders.
        to_stop_s = s.stamp_event_to_stop_s if s.stamp_event_to_stop_s is not None else s.event_to_stop_s
        to_rest_s = s.stamp_event_to_rest_s if s.stamp_event_to_rest_s is not None else s.event_to_rest_s
        assert to_rest_s <= GENEROUS_BOUND_S, s
        assert to_stop_s <= to_rest_s + 0.02, s  # the stop came first (within a tick)
