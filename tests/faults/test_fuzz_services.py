"""Bad payloads against running services: they stay alive and keep serving.

The bridge gets 10 000 random and 10 000 structurally mutated joint commands; the recorder,
which decodes every key, gets garbage on every key. Afterwards each service must still do
its job: the bridge publishes joint state at its rate and follows a valid command; the
recorder's file holds the messages sent after the flood.
"""

from __future__ import annotations

import random
import time

import numpy as np
import pytest

from bus_schema import TOPICS, topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from services.recorder.readback import read_scalars
from services.runtime.testing import ServiceProcess, wait_alive, wait_until
from tests.faults.mutations import random_payloads, structured_payloads
from tests.samples import SAMPLES

pytestmark = pytest.mark.integration


def _flood(pub, payloads, chunk=500):
    sent = 0
    for payload in payloads:
        pub.put_raw(payload)
        sent += 1
        if sent % chunk == 0:
            time.sleep(0.005)  # let the bridge's 100 Hz loop breathe between bursts
    return sent


def _max_gap_s(received):
    times = np.array([r.rx_monotonic for r in received])
    return float(np.max(np.diff(times))) if len(times) > 1 else float("inf")


@pytest.mark.fuzz_full
def test_bridge_survives_20000_bad_joint_commands(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge:
        wait_alive(router, profile, {"bridge"})
        node = make_node()
        states = node.subscribe(topics.JOINT_STATE, queue_size=100_000)
        cmd = node.publisher(topics.JOINT_COMMAND)
        assert wait_until(lambda: states.latest() is not None, 5)
        rng = random.Random(7)
        states.drain()
        sent = _flood(cmd, random_payloads(rng, 10_000))
        sent += _flood(cmd, structured_payloads(rng, SAMPLES["robot/joint_command"], 10_000))
        assert sent == 20_000
        during = states.drain()
        assert bridge.proc.poll() is None, bridge.log_text()[-2000:]
        # Still serving at its rate: no stall longer than a few ticks during the flood.
        assert during and _max_gap_s(during) < 0.5
        time.sleep(1.0)
        after = states.drain()
        assert 70 <= len(after) <= 130
        # And still obeys a valid command.
        target = np.array(RIGHT_ARM_HOME_RAD)
        target[2] += 0.2
        for _ in range(80):
            cmd.put(names=list(RIGHT_ARM_JOINTS), position_rad=list(target))
            time.sleep(0.01)
        assert abs(states.latest().msg.position_rad[2] - target[2]) < 0.01
        assert "dropped undecodable payload" in bridge.log_text()


def test_bridge_survives_a_quick_flood(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge:
        wait_alive(router, profile, {"bridge"})
        node = make_node()
        states = node.subscribe(topics.JOINT_STATE, queue_size=10_000)
        cmd = node.publisher(topics.JOINT_COMMAND)
        assert wait_until(lambda: states.latest() is not None, 5)
        rng = random.Random(3)
        _flood(cmd, random_payloads(rng, 1000))
        _flood(cmd, structured_payloads(rng, SAMPLES["robot/joint_command"], 1000))
        states.drain()
        time.sleep(0.5)
        assert bridge.proc.poll() is None
        assert len(states.drain()) >= 30


@pytest.mark.fuzz_full
def test_recorder_survives_garbage_on_every_key(bus, make_node, tmp_path):
    profile, router = bus
    output = tmp_path / "fuzz.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(output), "--no-urdf"]) as rec:
        wait_alive(router, profile, {"recorder"})
        node = make_node("fuzzer")
        rng = random.Random(11)
        for topic in TOPICS:
            pub = node.publisher(topic, own_stamps=topic is topics.HEARTBEAT)  # the node has its heartbeat
            _flood(pub, random_payloads(rng, 600))
            _flood(pub, structured_payloads(rng, SAMPLES[topic.suffix], 600))
        assert rec.proc.poll() is None, rec.log_text()[-2000:]
        marker = node.publisher(topics.WRIST_WRENCH)
        for i in range(20):
            marker.put(force_n=(123.0, float(i), 0.0))
            time.sleep(0.01)
        time.sleep(0.5)
        assert rec.stop() == 0
    series = read_scalars(output, "/bus/sensors/wrist_wrench/force_n/0")
    values = series["/bus/sensors/wrist_wrench/force_n/0"][1]
    assert np.count_nonzero(values == 123.0) == 20
