"""Release interrupt latency (issue 8 Must show): release event → arm speed zero, p99 ≤ 50 ms.

Run: python -m pytest tests/bench/test_bench_release_interrupt.py -m bench -s
The whole stack runs as real processes (`handover-up --job none --episodes 32 --receiver
absent`); in every episode the test publishes a `gripper/release` while the supervisor is in
``reach`` and the arm MOVES (max joint speed ≥ 0.2 rad/s), and measures from just before the
publication to the first `robot/joint_state` with every |v| < 0.01 rad/s
(`tests.faults.release_interrupt`). Baseline, same run: the supervisor's reaction alone
(release event → its `motion/stop` received by the test); the ratio is total / reaction.
Both are also measured by the senders' stamps (`stamp_ns`, one host clock: when the bridge
published the first joint state at rest, when the supervisor sent its stop), which leaves out
this test process's own receive delay when it is starved of CPU.
JSON: out/bench/release_interrupt.json.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.bench._report import save, summarize, table
from tests.faults.release_interrupt import measure_release_interrupts

pytestmark = [pytest.mark.bench, pytest.mark.timeout(1800)]

EPISODES = 32
MIN_SAMPLES = 30
#: On an overloaded machine the watchdog ends a stack now and then (bridge silent): start
#: another one until `MIN_SAMPLES` release interrupts are measured.
MAX_STACKS = 15
TARGET_P99_S = 0.050


def test_release_interrupt_latency_over_repeated_runs():
    samples: list = []
    stops: list[str] = []
    for stack in range(MAX_STACKS):  # a protective stop (watchdog on a loaded machine) ends a stack early
        if sum(s.event_to_rest_s is not None for s in samples) >= MIN_SAMPLES:
            break
        samples += measure_release_interrupts(EPISODES - len(samples), seed=1 + stack, protective_stops_out=stops)
    complete = [s for s in samples if s.event_to_rest_s is not None and s.event_to_stop_s is not None]
    assert len(complete) >= MIN_SAMPLES, f"only {len(complete)} complete release interrupts of {len(samples)}"
    total = summarize([s.event_to_rest_s for s in complete])
    reaction = summarize([s.event_to_stop_s for s in complete])
    state = summarize([s.event_to_released_state_s for s in complete if s.event_to_released_state_s is not None])
    speeds = np.array([s.speed_at_release_rad_s for s in complete])
    stamped = [s for s in complete if s.stamp_event_to_rest_s is not None and s.stamp_event_to_stop_s is not None]
    total_stamp = summarize([s.stamp_event_to_rest_s for s in stamped])
    reaction_stamp = summarize([s.stamp_event_to_stop_s for s in stamped])

    def cells(d):
        return tuple(f"{d[k] * 1000:.1f}" for k in ("median", "p90", "p99", "max"))

    rows = [
        ("release event → arm at rest (|v| < 0.01 rad/s), received", *cells(total)),
        ("release event → motion/stop (baseline), received", *cells(reaction)),
        ("release event → supervisor 'released', received", *cells(state)),
        ("release event → arm at rest, by the bridge's stamp", *cells(total_stamp)),
        ("release event → motion/stop, by the supervisor's stamp", *cells(reaction_stamp)),
    ]
    print()
    print(table(rows, ("latency (ms)", "median", "p90", "p99", "max")))
    print(f"n = {len(complete)}; arm speed at the release: median {np.median(speeds):.2f} rad/s, "
          f"min {speeds.min():.2f}, max {speeds.max():.2f}; ratio total/reaction (median) "
          f"{total['median'] / reaction['median']:.2f}; target p99 ≤ {TARGET_P99_S * 1000:.0f} ms; "
          f"stacks ended by a protective stop: {len(stops)} {stops}")
    save("release_interrupt", {
        "event_to_rest_s": total, "event_to_stop_s": reaction, "event_to_released_state_s": state,
        "stamp_event_to_rest_s": total_stamp, "stamp_event_to_stop_s": reaction_stamp,
        "ratio_total_to_reaction_median": total["median"] / reaction["median"],
        "speed_at_release_rad_s": {"median": float(np.median(speeds)), "min": float(speeds.min()),
                                   "max": float(speeds.max())},
        "protective_stops": stops, "target_p99_s": TARGET_P99_S, "meets_target_received": total["p99"] <= TARGET_P99_S,
        "meets_target_by_stamp": total_stamp["p99"] <= TARGET_P99_S,
        "samples": [vars(s) for s in samples],
    })
