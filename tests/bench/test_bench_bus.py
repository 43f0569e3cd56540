"""Bus hop latency between two processes, typed decode included, next to a raw Zenoh ping
measured in the same run (DESIGN §9: p50 ≤ 200 µs, p99 ≤ 1 ms, ≤ 1.5× raw).

Run: python -m pytest tests/bench/test_bench_bus.py -m bench -s
One hop = round trip / 2.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest

from bus_schema import topics
from bus_schema.topics import Topic
from services.runtime import ServiceNode, open_session
from services.runtime.testing import BusRouter, free_tcp_port, loopback_profile, wait_until
from tests.bench._report import save, summarize, table
from tests.bench.pong import PING, PONG

pytestmark = pytest.mark.bench
N_PINGS = 3000
WARMUP = 300


def _raw_round_trips(profile, n, user=None):
    session = open_session(profile, "client", user=user)
    got = threading.Event()
    stamp = [0.0]

    def on_pong(_sample):
        stamp[0] = time.perf_counter()
        got.set()

    sub = session.declare_subscriber(PONG, on_pong)
    pub = session.declare_publisher(PING)
    payload = bytes(100)
    rtts = []
    try:
        for i in range(n + WARMUP):
            got.clear()
            t0 = time.perf_counter()
            pub.put(payload)
            if not got.wait(1.0):
                raise AssertionError("raw pong did not answer within 1 s")
            if i >= WARMUP:
                rtts.append(stamp[0] - t0)
            time.sleep(0.0005)
    finally:
        sub.undeclare()
        pub.undeclare()
        session.close()
    return rtts


def _typed_round_trips(profile, n):
    pong_topic = Topic("pong", topics.WRIST_WRENCH.type, "state", 0, "bench", "pong")
    rtts = []
    with ServiceNode("ping", profile, install_signal_handlers=False) as node:
        sub = node.subscribe(pong_topic)
        pub = node.publisher(topics.WRIST_WRENCH)
        time.sleep(0.3)
        for i in range(n + WARMUP):
            sub.drain()
            t0 = time.monotonic()
            pub.put(force_n=(1.0, 2.0, 3.0), torque_nm=(0.1, 0.2, 0.3))
            deadline = t0 + 1.0
            while not sub.drain():
                if time.monotonic() > deadline:
                    raise AssertionError("typed pong did not answer within 1 s")
                node.wait(0.001)
            if i >= WARMUP:
                rtts.append(sub.latest().rx_monotonic - t0)
            time.sleep(0.0005)
    return rtts


def test_bus_hop_latency_vs_raw_zenoh():
    profile = loopback_profile(free_tcp_port(), "sim").with_bus(prefix="bench/typed")
    with BusRouter(profile) as router:
        results = {}
        for mode in ("raw", "typed"):
            proc = subprocess.Popen([sys.executable, "-m", "tests.bench.pong", "--endpoint", profile.endpoint,
                                     "--mode", mode])
            try:
                key = "bench/typed/alive/pong"
                assert wait_until(lambda: any(True for _ in router.liveliness().get(key, timeout=0.2)), 10)
                rtts = _raw_round_trips(profile, N_PINGS) if mode == "raw" else _typed_round_trips(profile, N_PINGS)
            finally:
                proc.terminate()
                proc.wait(10)
            results[mode] = summarize([r / 2 for r in rtts])
    ratio_median = results["typed"]["median"] / results["raw"]["median"]
    ratio_p99 = results["typed"]["p99"] / results["raw"]["p99"]
    rows = [(mode, f"{r['median'] * 1e6:.0f}", f"{r['p90'] * 1e6:.0f}", f"{r['p99'] * 1e6:.0f}", str(r["n"]))
            for mode, r in results.items()]
    print("\nOne bus hop between two processes (round trip / 2), µs")
    print(table(rows, ("path", "median", "p90", "p99", "samples")))
    print(f"typed / raw: median {ratio_median:.2f}x, p99 {ratio_p99:.2f}x")
    save("bus_hop", {**results, "ratio_median": ratio_median, "ratio_p99": ratio_p99})
    assert results["typed"]["median"] < 0.002  # generous sanity bound; targets are reported, not asserted
