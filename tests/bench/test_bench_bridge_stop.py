"""Bridge stop latency: `motion/stop` published → first `robot/joint_state` with the brake
engaged, received by the test (both ends on the test's monotonic clock).

Run: python -m pytest tests/bench/test_bench_bridge_stop.py -m bench -s
The bridge runs as a real process (sim backend, arm only) on a loopback bus; each trial moves
joint 0 at 0.8 rad/s, waits a random 0–10 ms (so stops land at every phase of the 100 Hz
tick), publishes a stop and waits for the braking joint state (`tests.integration.
test_bridge_stop.StopRig`). Baseline, same run: the old behaviour, the bridge started with
``--stop-on-tick`` (the stop waits for the next tick of the 10 ms grid). The ratio is
baseline / new. JSON: out/bench/bridge_stop.json.

Also here: the CPU of one sim-bridge tick per state of the scripted handover (rest with the
receiver, held still, transfer, moving empty, rest after a drop), this code against the last
commit before the cheaper tick, in one process (`tests.bench.bridge_tick_cpu`; offline, no bus).
JSON: out/bench/bridge_tick_cpu.json.
"""

from __future__ import annotations

import os

import pytest

from services.runtime import ServiceNode
from services.runtime.testing import BusRouter, ServiceProcess, loopback_profile, wait_alive
from tests.bench._report import save, summarize, table
from tests.integration.test_bridge_stop import run_trials, stop_ticks_from_log
from tests.bench import bridge_tick_cpu as tick_cpu

pytestmark = [pytest.mark.bench, pytest.mark.timeout(600)]

TRIALS = 60


def _measure(stop_on_tick: bool) -> tuple[list[float], int]:
    profile = loopback_profile()
    with BusRouter(profile) as router:
        bridge = ServiceProcess("services.bridge", profile,
                                ["--no-contact"] + (["--stop-on-tick"] if stop_on_tick else []))
        with bridge:
            wait_alive(router, profile, {"bridge"}, timeout_s=30)
            node = ServiceNode("bench", profile, install_signal_handlers=False)
            node.open()
            try:
                trials = run_trials(node, TRIALS)
            finally:
                node.close()
        return [t.latency_s for t in trials], stop_ticks_from_log(bridge.log_text())


def test_bridge_stop_latency_new_vs_tick_grid():
    load_before = os.getloadavg()[0]
    new, new_stop_ticks = _measure(stop_on_tick=False)
    old, old_stop_ticks = _measure(stop_on_tick=True)
    load_after = os.getloadavg()[0]
    s_new, s_old = summarize(new), summarize(old)
    stats = ("median", "p90", "p99", "max")
    rows = [
        ("stop wakes the loop (new)", *(f"{s_new[k] * 1000:.2f}" for k in stats), str(new_stop_ticks)),
        ("next 10 ms tick (baseline)", *(f"{s_old[k] * 1000:.2f}" for k in stats), str(old_stop_ticks)),
    ]
    ratio_median = s_old["median"] / s_new["median"]
    ratio_p99 = s_old["p99"] / s_new["p99"]
    print()
    print(table(rows, ("stop → braking joint state (ms)", "median", "p90", "p99", "max", "extra stop ticks")))
    print(f"baseline / new: median ×{ratio_median:.1f}, p99 ×{ratio_p99:.1f}; "
          f"load average {load_before:.2f} → {load_after:.2f} on {os.cpu_count()} cores")
    save("bridge_stop", {"new": s_new, "baseline_stop_on_tick": s_old, "ratio_median": ratio_median,
                         "ratio_p99": ratio_p99, "new_extra_stop_ticks": new_stop_ticks,
                         "trials": TRIALS, "load_average": [load_before, load_after]})
    assert s_new["n"] == TRIALS and s_old["n"] == TRIALS


@pytest.mark.parametrize("period_s", [0.0, 0.01], ids=["back_to_back", "paced_100hz"])
def test_bridge_tick_cpu_per_state_old_vs_new(tmp_path, period_s):
    samples = tick_cpu.compare(rounds=5 if period_s == 0.0 else 2, into=tmp_path, period_s=period_s)
    rows, results = [], {}
    for state in tick_cpu.STATES:
        old, new = (summarize(samples[v][state]) for v in ("baseline", "new"))
        results[state] = {"baseline_us": old, "new_us": new}
        rows.append((state, f"{old['median']:.1f}", f"{old['p99']:.1f}", f"{new['median']:.1f}", f"{new['p99']:.1f}"))
    print()
    print(table(rows, ("tick CPU (µs)", "baseline median", "p99", "new median", "p99")))
    save(f"bridge_tick_cpu_{'paced' if period_s else 'back_to_back'}", results)
    assert results["rest"]["new_us"]["median"] < results["rest"]["baseline_us"]["median"]
