"""Release interrupt with the whole stack: a release event while the arm moves stops it.

3 episodes of `handover-up --job none --receiver absent`; in each, a `gripper/release` is
published during the reach while the arm moves (see `release_interrupt`). Asserted: the
supervisor reacts (its `motion/stop` and its ``released`` state follow the event) and the
arm comes to rest, each time, within a generous 0.25 s (the issue's 50 ms p99 is measured by
tests/bench/test_bench_release_interrupt.py on 32 runs; timing on a shared CI machine is not
asserted tightly).
"""

from __future__ import annotations

import pytest

from tests.faults.release_interrupt import MOVING_RAD_S, measure_release_interrupts

pytestmark = [pytest.mark.integration, pytest.mark.timeout(240)]

GENEROUS_BOUND_S = 0.25


def test_a_release_during_the_reach_stops_the_moving_arm():
    samples = measure_release_interrupts(3, seed=2)
    assert len(samples) == 3, samples
    for s in samples:
        assert s.speed_at_release_rad_s >= MOVING_RAD_S  # the arm was moving
        assert s.event_to_stop_s is not None and s.event_to_released_state_s is not None, s
        assert s.event_to_rest_s is not None and s.event_to_rest_s <= GENEROUS_BOUND_S, s
        assert s.event_to_stop_s <= s.event_to_rest_s + 0.02, s  # the stop came first (within a tick)
