"""Recorder throughput and queue depth at the stack's full rates (DESIGN §9: no dropped messages).

Two writers with the same entities, measured in the same run on the same payloads:
- batched (the product): scalars and points sent as Arrow columns, joint transforms with
  `send_columns`, every 100 ms;
- baseline: one `rr.log` per entity per message (what the recorder did before).

Workload: one pre-encoded payload per message of every bus key at its nominal rate (event keys
at 10 Hz, depth 320×240 at 30 Hz), ≈ 1 000 messages/s; a second mix with the optical sensor at
1 kHz. Measured:
- sustained messages/s: the whole workload queued at once, time until it is written;
- queue depth: a producer thread queues the messages at their real rate for a few seconds
  (like the Zenoh callback), the recorder's own loop (`node.consume`) drains it; the queue's
  depth is sampled at every message handled.
Run: python -m pytest tests/bench/test_bench_recorder.py -m bench -s
"""

from __future__ import annotations

import queue
import threading
import time

import msgspec
import numpy as np
import pytest
import rerun as rr

from bus_schema import TOPICS, encode_for, messages as m, topics
from services.recorder.columns import TIMELINE_RECEIVE, TIMELINE_STAMP
from services.recorder.core import POINT_STYLES, event_key, message_rows
from services.recorder.node import consume, drain
from services.recorder.writer import RecordingWriter
from tests.bench._report import save, summarize, table
from tests.samples import SAMPLES

pytestmark = pytest.mark.bench
PREFIX = "handover/v1"
TICK_S = 0.01
PACED_S = 3.0


class PerMessageWriter(RecordingWriter):
    """Baseline: the same entities, each logged with its own `rr.log` call per message."""

    def handle(self, key: str, payload: bytes, receive_ns: int) -> None:
        from bus_schema import decode, topic_for_key

        topic = topic_for_key(key, self.prefix)
        msg = decode(topic, payload)
        self.stats.logged[topic.suffix] = self.stats.logged.get(topic.suffix, 0) + 1
        ekey = event_key(msg)
        fresh = ekey is not None and self._last_event.get(topic.suffix) != ekey
        if fresh:
            self._last_event[topic.suffix] = ekey
        rows = message_rows(topic, msg, log_event_text=fresh)
        if isinstance(msg, m.DepthImage):
            self._depth_seen += 1
            if (self._depth_seen - 1) % self.depth_every:
                rows.logs = [(e, a) for e, a in rows.logs if e != "camera/depth"]
        self.rec.set_time(TIMELINE_STAMP, timestamp=np.datetime64(msg.stamp_ns, "ns"))
        self.rec.set_time(TIMELINE_RECEIVE, timestamp=np.datetime64(receive_ns, "ns"))
        for entity, value in rows.scalars:
            self.rec.log(entity, rr.Scalars(value))
        for entity, xyz in rows.points:
            self.rec.log(entity, rr.Points3D([xyz], radii=POINT_STYLES[entity].radius_m))
        for entity, archetype in rows.logs + self._review.on_message(msg):
            self.rec.log(entity, archetype)
        if self._urdf is not None and isinstance(msg, m.JointState):
            for name, q in zip(msg.names, msg.position_rad, strict=False):
                joint = self._urdf.joints.get(name)
                if joint is not None:
                    self.rec.log("transforms", joint.compute_transform(q, clamp=True))


def _sample(topic) -> m.Message:
    if topic is topics.DEPTH:
        return msgspec.structs.replace(SAMPLES[topic.suffix], width=320, height=240,
                                       depth_mm=np.full(320 * 240, 1500, "<u2").tobytes())
    return SAMPLES[topic.suffix]


def workload(seconds: float, object_motion_hz: float) -> list[tuple[float, str, bytes]]:
    """(send time offset s, key, payload) for every message of `seconds` of the full stack."""
    rates = {t.suffix: (t.nominal_rate_hz or 10.0) for t in TOPICS} | {topics.OBJECT_MOTION.suffix: object_motion_hz}
    out: list[tuple[float, str, bytes]] = []
    owed = dict.fromkeys(rates, 0.0)
    t0_ns = time.time_ns()
    for tick in range(int(round(seconds / TICK_S))):
        for topic in TOPICS:
            owed[topic.suffix] += rates[topic.suffix] * TICK_S
            while owed[topic.suffix] >= 1.0:
                owed[topic.suffix] -= 1.0
                offset = tick * TICK_S
                msg = msgspec.structs.replace(_sample(topic), seq=len(out), stamp_ns=t0_ns + int(offset * 1e9) + len(out))
                out.append((offset, topic.key(PREFIX), encode_for(topic, msg)))
    return out


def _sustained(writer_type, messages, path) -> float:
    writer = writer_type(path, PREFIX)
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    for _, key, payload in messages:
        inbox.put((key, payload, time.time_ns()))
    t0 = time.perf_counter()
    drain(inbox, writer)
    writer.close()
    return len(messages) / (time.perf_counter() - t0)


def _paced(writer_type, messages, path) -> tuple[list[int], int]:
    """Queue depths seen while a producer thread queues `messages` at their real times."""
    writer = writer_type(path, PREFIX)
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    depths: list[int] = []
    done = threading.Event()
    handle = writer.handle

    def sampled(key, payload, receive_ns):
        depths.append(inbox.qsize())
        handle(key, payload, receive_ns)

    writer.handle = sampled  # type: ignore[method-assign]

    def produce():
        t0 = time.monotonic()
        for offset, key, payload in messages:
            delay = t0 + offset - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            inbox.put((key, payload, time.time_ns()))
        done.set()

    producer = threading.Thread(target=produce)
    producer.start()
    consume(inbox, writer, lambda: done.is_set() and inbox.qsize() == 0)
    producer.join()
    drain(inbox, writer)
    writer.close()
    return depths, sum(writer.stats.logged.values())


def test_recorder_throughput_and_queue_depth(tmp_path):
    results, rows = {}, []
    for label, obj_hz in (("full rates (optical 100 Hz)", 100.0), ("optical sensor at 1 kHz", 1000.0)):
        msgs = workload(PACED_S, obj_hz)
        rate = len(msgs) / PACED_S
        entry = {"offered_msgs_per_s": rate}
        for name, writer_type in (("batched", RecordingWriter), ("per-message rr.log", PerMessageWriter)):
            sustained = _sustained(writer_type, msgs, tmp_path / f"s-{name[:5]}-{obj_hz:.0f}.rrd")
            depths, logged = _paced(writer_type, msgs, tmp_path / f"p-{name[:5]}-{obj_hz:.0f}.rrd")
            assert logged == len(msgs)
            d = np.asarray(depths, dtype=float)
            entry[name] = {"sustained_msgs_per_s": sustained, "queue_median": float(np.median(d)),
                           "queue_p99": float(np.percentile(d, 99)), "queue_max": float(d.max())}
            rows.append((label, name, f"{rate:.0f}", f"{sustained:.0f}", f"{np.median(d):.0f}",
                         f"{np.percentile(d, 99):.0f}", f"{d.max():.0f}"))
        entry["ratio_sustained_batched_over_baseline"] = (entry["batched"]["sustained_msgs_per_s"]
                                                         / entry["per-message rr.log"]["sustained_msgs_per_s"])
        results[label] = entry
    print("\nrecorder: sustained throughput and queue depth (messages)")
    print(table(rows, ("workload", "writer", "offered msg/s", "sustained msg/s", "queue median",
                       "queue p99", "queue max")))
    for label, entry in results.items():
        print(f"{label}: batched sustains {entry['ratio_sustained_batched_over_baseline']:.1f}x the baseline")
    save("recorder", results)
    full = results["full rates (optical 100 Hz)"]
    assert full["batched"]["sustained_msgs_per_s"] > full["offered_msgs_per_s"]
