"""What a Zenoh put costs in a 100 Hz loop, against what it costs in a hot loop (the
"where the CPU goes" finding of docs/performance.md).

A publisher process sends the bridge's three sensor messages of one tick (370, 114 and
168 bytes, raw Zenoh puts on one session with the stack's one-worker Zenoh runtime) to three
readers through a router process, either back to back (hot) or once every 10 ms on the
host's grid, asleep in between, as the bridge's loop does (paced). A fourth variant sleeps and
sends nothing: the cost of the wake alone. CPU per tick, µs: the sending thread
(`time.thread_time`) and the whole process (Zenoh's worker included, `getrusage`). Rounds
alternate the variants; medians over the rounds.

Run: python -m pytest tests/bench/test_bench_put_cold.py -m bench -s
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys

import pytest

from services.launcher.processes import RouterProcess
from services.runtime.testing import interrupt_then_kill, loopback_profile
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime.zenoh_threads import ONE_WORKER_THREAD, ZENOH_RUNTIME_ENV
from tests.bench._report import save, table

pytestmark = pytest.mark.bench
ROUNDS = 3
PAYLOAD_SIZES = (370, 114, 168)  # joint state, wrist wrench, object motion (bytes, as encoded)

_SENDER = r"""
import json, resource, sys, time
from services.runtime.node import open_session
from services.runtime.testing import loopback_profile
profile = loopback_profile(int(sys.argv[1])); sends = sys.argv[2] == "puts"; ticks = 500
session = open_session(profile, "client")
publishers = [session.declare_publisher(f"bench/put_cold/{k}") for k in range(3)]
payloads = [bytes(n) for n in json.loads(sys.argv[3])]
def tick():
    if sends:
        for publisher, payload in zip(publishers, payloads):
            publisher.put(payload)
for _ in range(300):
    tick()
t0 = time.thread_time()
for _ in range(2000):
    tick()
hot_us = (time.thread_time() - t0) / 2000 * 1e6
period = 0.01
start = (time.monotonic() // period + 2) * period
t0, r0 = time.thread_time(), resource.getrusage(resource.RUSAGE_SELF)
for k in range(1, ticks + 1):
    delay = start + k * period - time.monotonic()
    if delay > 0:
        time.sleep(delay)
    tick()
r1 = resource.getrusage(resource.RUSAGE_SELF)
process_us = (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime) / ticks * 1e6
print(json.dumps({"hot_us": hot_us, "paced_thread_us": (time.thread_time() - t0) / ticks * 1e6,
                  "paced_process_us": process_us}))
session.close()
"""

_READER = r"""
import sys, time, zenoh
from services.runtime.node import open_session
from services.runtime.testing import loopback_profile
session = open_session(loopback_profile(int(sys.argv[1])), "client")
subscriber = session.declare_subscriber("bench/put_cold/**", zenoh.handlers.RingChannel(8))
sys.stdin.read()  # until the bench closes our stdin
"""


def test_put_cost_hot_against_paced() -> None:
    profile = loopback_profile()
    port = profile.endpoint.rsplit(":", 1)[1]
    env = dict(os.environ, **{ZENOH_RUNTIME_ENV: ONE_WORKER_THREAD})
    router = RouterProcess(json.dumps(zenoh_config_dict(profile, "router")), verbose=False)
    router.start()
    readers: list[subprocess.Popen] = []
    results: dict[str, list[dict]] = {"puts": [], "wake only": []}
    try:
        readers = [subprocess.Popen([sys.executable, "-c", _READER, port], stdin=subprocess.PIPE, env=env)
                   for _ in range(3)]
        for _ in range(ROUNDS):
            for variant in ("wake only", "puts"):
                done = subprocess.run([sys.executable, "-c", _SENDER, port, variant.split()[0],
                                       json.dumps(PAYLOAD_SIZES)], env=env, capture_output=True, text=True,
                                      timeout=120)
                assert done.returncode == 0, done.stderr[-2000:]
                results[variant].append(json.loads(done.stdout))
    finally:
        for reader in readers:
            if reader.stdin is not None:
                reader.stdin.close()
            interrupt_then_kill(reader, 5.0)
        router.stop()
    median = {v: {k: statistics.median(r[k] for r in runs) for k in runs[0]} for v, runs in results.items()}
    save("put_cold", {"rounds": results, "median": median})
    rows = [(v, f"{m['hot_us']:.1f}", f"{m['paced_thread_us']:.0f}", f"{m['paced_process_us']:.0f}")
            for v, m in median.items()]
    print()
    print(table(rows, ("3 puts a tick", "hot, sending thread (µs)", "paced 100 Hz, sending thread (µs)",
                       "paced 100 Hz, whole process (µs)")))
    puts, wake = median["puts"], median["wake only"]
    # The finding the docs state: a paced tick's puts cost many times their hot cost.
    assert puts["paced_thread_us"] - wake["paced_thread_us"] > 5 * puts["hot_us"], median
