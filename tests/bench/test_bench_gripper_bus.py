"""Gripper service through the bus: sensor sample in → grip command out (DESIGN §9: p99 ≤ 1 ms,
keeps up with 1 kHz sensor input), next to a typed echo process measured in the same run.

Both are round trips between two processes (sample out, answer back): the echo is the bus
cost alone, the gripper adds its decode, freshness checks, FS1 step and publications. The
gripper runs twice in the same run: stepping in the main thread after the queue hand-off
(the default) and stepping inside the sensor callback (`--step-in-callback`, one thread
wake-up less).
Run: python -m pytest tests/bench/test_bench_gripper_bus.py -m bench -s
"""

from __future__ import annotations

import re
import subprocess
import sys
import time

import pytest

from bus_schema import topics
from bus_schema.topics import Topic
from services.runtime import ServiceNode
from services.runtime.liveliness import alive_services
from services.runtime.testing import BusRouter, ServiceProcess, free_tcp_port, loopback_profile, wait_alive, wait_until
from tests.bench._report import save, summarize, table

pytestmark = pytest.mark.bench
N, WARMUP = 2000, 200


def _wait_new(sub, node, deadline, accept=lambda r: True):
    while True:
        for r in sub.drain():
            if accept(r):
                return r
        if time.monotonic() > deadline:
            raise AssertionError("no answer within 1 s")
        node.wait(0.0005)


def _gripper_round_trips(node):
    cmd = node.subscribe(topics.GRIPPER_COMMAND, queue_size=4096)
    wrench, motion = node.publisher(topics.WRIST_WRENCH), node.publisher(topics.OBJECT_MOTION)
    out, last = [], None
    for i in range(N + WARMUP):
        cmd.drain()
        motion.put(displacement_counts=(0, 0), counts_per_m=15748.0, dt_s=0.001)
        t0 = time.monotonic()
        wrench.put(force_n=(float(i % 2), 5.0, 0.0))
        prev = last
        r = _wait_new(cmd, node, t0 + 1.0, lambda r: r.msg.mode != "hold" and r.msg.grip_force_n != prev)
        last = r.msg.grip_force_n
        if i >= WARMUP:
            out.append(r.rx_monotonic - t0)
        time.sleep(0.0008)
    return out


def _keep_up(node, seconds=2.0, rate_hz=1000.0):
    cmd = node.subscribe(topics.GRIPPER_COMMAND, queue_size=20000)
    wrench, motion = node.publisher(topics.WRIST_WRENCH), node.publisher(topics.OBJECT_MOTION)
    time.sleep(0.1)
    cmd.drain()
    period, t_next, sent = 1.0 / rate_hz, time.monotonic(), 0
    end = t_next + seconds
    while t_next < end:
        motion.put(displacement_counts=(0, 0), counts_per_m=15748.0, dt_s=period)
        wrench.put(force_n=(0.0, 5.0 + 0.001 * (sent % 200), 0.0))  # every sample moves the command
        sent += 1
        t_next += period
        pause = t_next - time.monotonic()
        if pause > 0:
            time.sleep(pause)
    time.sleep(0.2)
    values = [r.msg.grip_force_n for r in cmd.drain() if r.msg.mode != "hold"]
    steps = 1 + sum(1 for a, b in zip(values, values[1:]) if a != b)
    return sent, steps, seconds * rate_hz / (time.monotonic() - (end - seconds) - 0.2 + 1e-9)


def _in_service_latency_us(log_text: str) -> dict[str, float]:
    """The gripper's own measurement, logged when it stops: wrench sample received (Zenoh
    callback) → grip command published, median and p99 in µs over its last 20 000 steps."""
    m = re.search(r"gripper stopped .*latency_samples=(\d+) latency_median_us=([0-9.]+) latency_p99_us=([0-9.]+)",
                  log_text)
    assert m, f"no latency summary in the gripper's log:\n{log_text[-2000:]}"
    return {"samples": int(m.group(1)), "median_us": float(m.group(2)), "p99_us": float(m.group(3))}


def _echo_round_trips(profile):
    pong = Topic("pong", topics.WRIST_WRENCH.type, "state", 0, "bench", "pong")
    with ServiceNode("ping", profile, install_signal_handlers=False) as node:
        sub, pub = node.subscribe(pong), node.publisher(topics.WRIST_WRENCH)
        time.sleep(0.3)
        out = []
        for i in range(N + WARMUP):
            sub.drain()
            t0 = time.monotonic()
            pub.put(force_n=(1.0, 2.0, 3.0))
            r = _wait_new(sub, node, t0 + 1.0)
            if i >= WARMUP:
                out.append(r.rx_monotonic - t0)
            time.sleep(0.0008)
    return out


def test_gripper_sample_to_command_latency_and_1khz():
    profile = loopback_profile(free_tcp_port(), "sim").with_bus(prefix="bench/typed")
    with BusRouter(profile) as router:
        proc = subprocess.Popen([sys.executable, "-m", "tests.bench.pong", "--endpoint", profile.endpoint,
                                 "--mode", "typed"])
        try:
            assert wait_until(
                lambda: any(True for _ in router.liveliness().get("bench/typed/alive/pong", timeout=0.2)), 10)
            echo = _echo_round_trips(profile)
        finally:
            proc.terminate()
            proc.wait(10)
        base = ["--controller", "FS1", "--rate-hz", "1000", "--log-level", "warning"]
        with ServiceProcess("services.gripper", profile, args=base + ["--log-level", "info"]) as gripper:
            wait_alive(router, profile, {"gripper"})
            with ServiceNode("bench", profile, install_signal_handlers=False) as node:
                time.sleep(0.3)
                grip = _gripper_round_trips(node)
                sent, steps, _ = _keep_up(node)
            gripper.stop()
            in_service = _in_service_latency_us(gripper.log_text())
        assert wait_until(lambda: "gripper" not in alive_services(router, profile.prefix, timeout_s=0.2), 10)
        with ServiceProcess("services.gripper", profile, args=base + ["--step-in-callback"]):
            wait_alive(router, profile, {"gripper"})
            with ServiceNode("bench", profile, install_signal_handlers=False) as node:
                time.sleep(0.3)
                callback = _gripper_round_trips(node)
    res = {"echo_round_trip": summarize(echo), "gripper_round_trip": summarize(grip),
           "gripper_step_in_callback_round_trip": summarize(callback)}
    ratio = res["gripper_round_trip"]["median"] / res["echo_round_trip"]["median"]
    rows = [(k, f"{v['median'] * 1e6:.0f}", f"{v['p90'] * 1e6:.0f}", f"{v['p99'] * 1e6:.0f}", str(v["n"]))
            for k, v in res.items()]
    print("\nSensor sample in -> grip command out, round trip between two processes, µs")
    print(table(rows, ("path", "median", "p90", "p99", "samples")))
    cb = res["gripper_step_in_callback_round_trip"]
    print(f"gripper / typed echo: {ratio:.2f}x (median); step in callback / in main thread: "
          f"{cb['median'] / res['gripper_round_trip']['median']:.2f}x (median), "
          f"{cb['p99'] / res['gripper_round_trip']['p99']:.2f}x (p99); "
          f"1 kHz stream: {sent} samples in, {steps} controller steps out")
    print(f"inside the gripper service (sample received -> command published), {in_service['samples']} steps: "
          f"median {in_service['median_us']:.0f} µs, p99 {in_service['p99_us']:.0f} µs "
          "(DESIGN §9 target: p99 ≤ 1000 µs)")
    save("gripper_bus", {**res, "ratio_median_vs_echo": ratio, "keep_up_1khz": {"samples": sent, "steps": steps},
                         "in_service_sample_to_command": in_service})
    # Samples that arrive bunched (sender or bus jitter) closer than a quarter period to the
    # previous step are merged into the next grid step (the latest sample is used), so a few
    # percent fewer steps than samples is the design, not a backlog.
    assert steps >= 0.9 * sent, f"the service fell behind at 1 kHz: {steps} steps for {sent} samples"
    assert res["gripper_round_trip"]["p99"] < 0.005  # generous bound; the 1 ms target is reported
