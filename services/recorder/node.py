"""Bus wiring of the recorder: everything under ``<prefix>/**`` into one .rrd per run.

Start-up order (the launcher waits for the recorder before it starts anything else): open the
session, declare the liveliness token and subscribe first, and only then import Rerun and
load Baxter's model; messages that arrive meanwhile wait in the queue. The Zenoh callback
only enqueues (key, payload, receive time in ns); the main thread decodes and writes through
`writer.RecordingWriter`, which batches and flushes every `batch_period_s`. On SIGTERM/SIGINT
the recorder keeps listening until the bus has been quiet for 0.15 s (at most 1 s: the last
service's final messages may still be in flight), drains the queue, writes and flushes before exit; on SIGKILL the file is valid up
to the last flush.

This module imports neither Rerun nor NumPy at import time (start-up speed).
"""

from __future__ import annotations

import logging
import queue
import time
from pathlib import Path

from services.runtime import Profile, ServiceNode, kv

log = logging.getLogger(__name__)

SERVICE_NAME = "recorder"


def consume(inbox: queue.SimpleQueue, writer, should_stop, on_tick=lambda: None) -> None:
    """Hand queued (key, payload, receive_ns) to `writer` and let it write when due, until
    `should_stop()`; calls `on_tick()` (the heartbeat) at least every 20 ms; records the queue's
    peak depth in `writer.stats.max_queue`."""
    stats = writer.stats
    while not should_stop():
        on_tick()
        try:
            key, payload, receive_ns = inbox.get(timeout=0.02)
        except queue.Empty:
            key = None
        if key is not None:
            writer.handle(key, payload, receive_ns)
            stats.max_queue = max(stats.max_queue, inbox.qsize())
        writer.pump()


def drain(inbox: queue.SimpleQueue, writer) -> None:
    """Hand everything still queued to `writer` (no waiting)."""
    while True:
        try:
            key, payload, receive_ns = inbox.get_nowait()
        except queue.Empty:
            return
        writer.handle(key, payload, receive_ns)


def settle(inbox: queue.SimpleQueue, writer, quiet_s: float = 0.15, max_s: float = 1.0) -> None:
    """After a stop request: keep handing over messages until none arrived for `quiet_s`
    (at most `max_s`). The launcher stops the recorder right after the last other service,
    whose final messages may still be on their way through the router."""
    deadline = time.monotonic() + max_s
    while (left := deadline - time.monotonic()) > 0:
        try:
            key, payload, receive_ns = inbox.get(timeout=min(quiet_s, left))
        except queue.Empty:
            return
        writer.handle(key, payload, receive_ns)


def default_output_path(directory: Path, run_id: str) -> Path:
    return directory / f"handover-{run_id}.rrd"


def run_recorder(profile: Profile, output: Path, log_urdf: bool = True,
                 flush_period_s: float = 0.1, application_id: str = "handover",
                 depth_every: int = 3) -> int:
    """Record the bus into `output` until SIGINT/SIGTERM.

    `flush_period_s`: how often buffered rows are written and the file flushed (the most a
    SIGKILL can lose). Depth images (150 kB each at 30 Hz) are logged one in `depth_every`
    to keep recordings small; every other message is logged.
    """
    inbox: queue.SimpleQueue[tuple[str, bytes, int]] = queue.SimpleQueue()

    def on_sample(sample) -> None:  # Zenoh thread: enqueue only
        inbox.put((str(sample.key_expr), sample.payload.to_bytes(), time.time_ns()))

    with ServiceNode(SERVICE_NAME, profile) as node:
        subscriber = node.session.declare_subscriber(f"{profile.prefix}/**", on_sample)
        node.ready()  # alive = listening: nothing may be published before the recorder hears it
        from services.recorder.writer import RecordingWriter  # Rerun, NumPy, PyArrow: after subscribing

        writer = RecordingWriter(output, profile.prefix, log_urdf=log_urdf, batch_period_s=flush_period_s,
                                 depth_every=depth_every, application_id=application_id)
        stats = writer.stats
        log.info("recording", extra=kv(output=str(output), keys=f"{profile.prefix}/**"))
        try:
            consume(inbox, writer, lambda: node.should_stop, node.heartbeat)
            settle(inbox, writer)
        finally:
            subscriber.undeclare()
            drain(inbox, writer)  # what arrived before the subscriber closed
            writer.close()
            log.info("recording closed", extra=kv(output=str(output), messages=sum(stats.logged.values()),
                                                 rejected=stats.rejected, max_queue=stats.max_queue))
    return 0
