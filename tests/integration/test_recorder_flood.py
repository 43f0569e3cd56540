"""The recorder as a real process under a flood at (above) the stack's full rates: nothing dropped.

Every key of the bus is published at its nominal rate from `bus_schema.topics` (event keys at
10 Hz) with the optical sensor at 1 kHz (DESIGN's upper bound), for a few seconds, through
publishers with congestion control BLOCK (so that the only place a message could be lost is
the recorder). The recording read back must hold exactly one row per message sent on every
key, at the sender's stamp, plus the review entities. Depth images are asked for (one in 3), so
that every key of the table is flooded.
"""

from __future__ import annotations

import math
from collections import Counter
import signal
import time

import msgspec
import pytest
import zenoh

from bus_schema import TOPICS as ALL_TOPICS
from bus_schema import encode_for, topics
from services.recorder.core import numeric_fields
from services.recorder.readback import entity_row_counts, read_scalars
from services.runtime.testing import ServiceProcess, wait_alive
from tests.samples import SAMPLES

pytestmark = pytest.mark.integration

FLOOD_S = 3.0
TICK_S = 0.01
#: Messages per second per key in the flood (the optical sensor at its 1 kHz maximum).
#: Every key the recorder records (the simulation clock's steps and answers it leaves out).
TOPICS = tuple(t for t in ALL_TOPICS if t not in (topics.CLOCK, topics.CLOCK_READY))
RATES_HZ = {t.suffix: (t.nominal_rate_hz or 10.0) for t in TOPICS} | {topics.OBJECT_MOTION.suffix: 1000.0}


def _first_series(suffix: str) -> str:
    """The first scalar entity a message of `suffix` yields (its count = messages recorded)."""
    path, _ = next(iter(numeric_fields(SAMPLES[suffix])))
    return f"/bus/{suffix}/{path}"


def _flood(session: zenoh.Session, prefix: str) -> dict[str, list[int]]:
    """Publish every key at RATES_HZ for FLOOD_S; returns the stamps sent per key."""
    pubs = {t.suffix: session.declare_publisher(t.sender_key(SAMPLES[t.suffix].source, prefix),
                                                congestion_control=zenoh.CongestionControl.BLOCK)
            for t in TOPICS}
    sent: dict[str, list[int]] = {t.suffix: [] for t in TOPICS}
    owed = dict.fromkeys(sent, 0.0)
    t0 = time.monotonic()
    tick = 0
    while time.monotonic() - t0 < FLOOD_S:
        for topic in TOPICS:
            owed[topic.suffix] += RATES_HZ[topic.suffix] * TICK_S
            while owed[topic.suffix] >= 1.0:
                owed[topic.suffix] -= 1.0
                stamp = time.time_ns() + len(sent[topic.suffix])  # unique per key
                msg = msgspec.structs.replace(SAMPLES[topic.suffix], seq=len(sent[topic.suffix]), stamp_ns=stamp)
                pubs[topic.suffix].put(encode_for(topic, msg))
                sent[topic.suffix].append(stamp)
        tick += 1
        time.sleep(max(0.0, t0 + tick * TICK_S - time.monotonic()))
    for pub in pubs.values():
        pub.undeclare()
    return sent


def test_flood_at_full_rates_drops_nothing(bus, make_node, tmp_path):
    profile, router = bus
    out = tmp_path / "flood.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out), "--depth-every", "3"]) as rec:
        wait_alive(router, profile, {"recorder"})
        node = make_node()
        time.sleep(0.3)  # the recorder's subscription reaches the router
        sent = _flood(node.session, profile.prefix)
        time.sleep(0.5)
        rec.proc.send_signal(signal.SIGTERM)
        assert rec.proc.wait(60) == 0, rec.log_text()
        log_text = rec.log_text()

    total = sum(len(v) for v in sent.values())
    assert total >= FLOOD_S * 1500 * 0.9  # the flood really was above the stack's ~900 msg/s
    counts = entity_row_counts(out, include_static=False)
    series = read_scalars(out, "/bus")
    for suffix, stamps in sent.items():
        times = series[_first_series(suffix)][0].tolist()
        recorded = Counter(times)
        missing = [s for s in stamps if recorded[s] != 1]
        assert not missing, f"{suffix}: {len(missing)} of {len(stamps)} sent messages not recorded once"
        if suffix != topics.HEARTBEAT.suffix:  # every service (and this test's node) beats too
            assert len(times) == len(stamps), f"{suffix}: sent {len(stamps)}, recorded {len(times)}"
    # Depth images: one in three (the numbers of every frame are above).
    assert counts["/camera/depth"] == math.ceil(len(sent["perception/depth"]) / 3)
    # Every message at its own stamp, values intact.
    fx = series["/bus/sensors/wrist_wrench/force_n/0"]
    assert fx[0].tolist() == sent["sensors/wrist_wrench"]
    assert set(fx[1].tolist()) == {SAMPLES["sensors/wrist_wrench"].force_n[0]}
    recorded_total = sum(len(series[_first_series(suffix)][0]) for suffix in sent)  # heartbeats included
    assert f"messages={recorded_total} rejected=0" in log_text
