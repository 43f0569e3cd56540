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

Memory (DESIGN §9: ≤ 300 MB RSS), `test_recorder_rss_*`: a subprocess builds the recorder's
writer (Baxter's URDF included), feeds it `RSS_DATA_S` seconds of the full-rate workload (as
fast as it can, a batch every 0.1 s of data) and closes the file, while a thread samples its
RSS every 5 ms. Two variants in the same run:
- product: the recorder as it is (footer-less file, mimalloc returns freed pages);
- baseline: the previous settings (Rerun's footer written, mimalloc defaults).
Run: python -m pytest tests/bench/test_bench_recorder.py -m bench -s
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
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


RSS_DATA_S = 30
TARGET_RSS_MB = 300.0

#: Runs in a fresh interpreter: argv = output .rrd, seconds of data, "product" | "baseline".
_RSS_SCRIPT = r"""
import json, sys, threading, time
import psutil
out, seconds, variant = sys.argv[1], int(sys.argv[2]), sys.argv[3]
proc = psutil.Process()
peak = [0]
def sample():
    while True:
        peak[0] = max(peak[0], proc.memory_info().rss)
        time.sleep(0.005)
threading.Thread(target=sample, daemon=True).start()
if variant == "baseline":
    import rerun as rr  # before the writer: its allocator settings come too late to apply
    save = rr.RecordingStream.save
    rr.RecordingStream.save = lambda self, path, **kw: save(self, path)  # footer written (the default)
from pathlib import Path
from services.recorder.writer import RecordingWriter
from tests.bench.test_bench_recorder import PREFIX, workload
mb = lambda b: b / 1e6
writer = RecordingWriter(Path(out), PREFIX)
after_init = proc.memory_info().rss
peak[0] = 0
feed_s = 0.0
for _ in range(seconds):
    messages = workload(1.0, 100.0)
    t_feed = time.perf_counter()
    for i, (_, key, payload) in enumerate(messages):
        writer.handle(key, payload, time.time_ns())
        if i % max(1, len(messages) // 10) == 0:
            writer.pump(force=True)
    feed_s += time.perf_counter() - t_feed
before_close = proc.memory_info().rss
feed_peak = peak[0]
peak[0] = 0
t0 = time.perf_counter()
writer.close()
close_s = time.perf_counter() - t0
time.sleep(0.05)
close_peak = max(peak[0], proc.memory_info().rss)
print(json.dumps({"after_init_mb": mb(after_init), "feed_peak_mb": mb(feed_peak), "before_close_mb": mb(before_close),
                  "close_peak_mb": mb(close_peak), "peak_mb": mb(max(feed_peak, close_peak, after_init)),
                  "close_s": close_s, "messages": sum(writer.stats.logged.values()),
                  "msgs_per_s": sum(writer.stats.logged.values()) / feed_s}))
"""


def _rss_run(variant: str, path) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("MIMALLOC_PURGE_DELAY", "RUST_LOG")}
    done = subprocess.run([sys.executable, "-c", _RSS_SCRIPT, str(path), str(RSS_DATA_S), variant],
                          capture_output=True, text=True, env=env, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["file_mb"] = path.stat().st_size / 1e6
    return result


def test_recorder_rss_product_vs_previous_settings(tmp_path):
    from services.recorder.readback import entity_row_counts

    results = {variant: _rss_run(variant, tmp_path / f"{variant}.rrd") for variant in ("product", "baseline")}
    rows = [(variant, f"{r['after_init_mb']:.0f}", f"{r['before_close_mb']:.0f}", f"{r['feed_peak_mb']:.0f}",
             f"{r['close_peak_mb']:.0f}", f"{r['peak_mb']:.0f}", f"{r['close_s']:.2f}", f"{r['file_mb']:.0f}",
             f"{r['msgs_per_s']:.0f}")
            for variant, r in results.items()]
    print(f"\nrecorder RSS, MB: URDF + {RSS_DATA_S} s of data at the stack's full rates (target ≤ {TARGET_RSS_MB:.0f})")
    print(table(rows, ("variant", "after start", "before close", "peak while writing", "peak at close", "peak",
                       "close s", "file MB", "written msg/s")))
    product, baseline = results["product"], results["baseline"]
    results["ratio_peak_product_over_baseline"] = product["peak_mb"] / baseline["peak_mb"]
    print(f"peak RSS: product {product['peak_mb']:.0f} MB = {results['ratio_peak_product_over_baseline']:.2f}x "
          f"the previous settings ({baseline['peak_mb']:.0f} MB)")
    save("recorder_rss", results)
    # Same data in both files: every message written (the footer only indexes it).
    assert product["messages"] == baseline["messages"] > RSS_DATA_S * 900
    counts = entity_row_counts(tmp_path / "product.rrd", include_static=False)
    assert counts == entity_row_counts(tmp_path / "baseline.rrd", include_static=False)
