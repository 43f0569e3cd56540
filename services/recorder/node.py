"""Bus wiring of the recorder: every key of the topic table into one .rrd per run.

Subscriptions: one per key of `bus_schema.TOPICS` (`config.recorded_topics`), not
``<prefix>/**``: keys the recorder does not record never reach the process. Depth images
(150 kB at 30 Hz: 4.6 MB/s) are subscribed only with ``depth_every`` ≥ 1; keys outside the
table (which it could not decode) are not subscribed at all, so a stranger publishing on
thousands of keys costs the recorder nothing.

Intake: each key's subscription hands its samples to a Zenoh ring channel (in Rust: no Python
callback thread, no GIL, no wake-up per message; a callback subscription costs one Python
thread per key and ~20 µs of CPU per message). The main thread sleeps until the next flush
(`flush_period_s`), then `writer.RecordingWriter` drains the channels, decodes, writes and
flushes the file. Receive time: the sample's timestamp, stamped by the Zenoh router when it
received the message (routers timestamp by default). A sample without one was delivered inside
the recorder's own session (its heartbeats): its receive time is its send stamp. Any other key
without timestamps (no router, or timestamping turned off) gets the same and is logged once.
A channel holds `QUEUE_CAPACITY` messages (depth: `DEPTH_QUEUE_CAPACITY`): a main thread stalled
for minutes loses its oldest messages (gaps in the recorded ``seq``) and never blocks the bus.

Start-up order (the launcher waits for the recorder before it starts anything else): open the
session, subscribe and declare the liveliness token first, and only then import Rerun and load
the arm's model; messages that arrive meanwhile wait in the channels. On SIGTERM/SIGINT the
recorder keeps listening until the bus has been quiet for 0.15 s (at most 1 s: the last
service's final messages may still be in flight), then writes, flushes and finalises the file
(`finalise`: Rerun's footer, so that ``rerun rrd verify`` passes) before exit; on SIGKILL the
file is readable up to the last flush, without footer (``handover-recorder finalise FILE``).

This module imports neither Rerun nor NumPy at import time (start-up speed).
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path

from bus_schema.topics import DEPTH, HEARTBEAT
from services.recorder.config import RecorderConfig, recorded_topics
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv

log = logging.getLogger(__name__)

SERVICE_NAME = "recorder"

#: Messages a key's channel holds before it drops its oldest (~5 min of the busiest key).
QUEUE_CAPACITY = 50_000
#: The same for depth images (150 kB each): ~8 s at 30 Hz, 40 MB.
DEPTH_QUEUE_CAPACITY = 256


def consume(writer, stop: threading.Event) -> None:
    """Until `stop` is set: sleep until the writer's next flush, then let it collect and write."""
    while not stop.wait(writer.seconds_to_flush()):
        writer.pump()


def settle(collect: Callable[[], int], quiet_s: float = 0.15, max_s: float = 1.0, poll_s: float = 0.01) -> float:
    """After a stop request: keep collecting (`collect()` returns how many messages it took)
    until none arrived for `quiet_s` (at most `max_s`); returns the seconds waited. The launcher
    stops the recorder right after the last other service, whose final messages may still be on
    their way through the router."""
    t0 = last_seen = time.monotonic()
    while (now := time.monotonic()) - t0 < max_s and now - last_seen < quiet_s:
        time.sleep(poll_s)
        if collect():
            last_seen = time.monotonic()
    return time.monotonic() - t0


#: Receive time of a sample that carries no router timestamp: the writer uses the message's stamp.
NO_RECEIVE_TIME = -1


def channel_source(subscriber, topic, missing_stamp: RateLimitedLog) -> Callable[[], list[tuple[bytes, int]]]:
    """A writer source draining `subscriber`'s channel: (payload, receive time ns) per sample,
    the receive time from the router's timestamp (`NO_RECEIVE_TIME` when it has none)."""
    def take() -> list[tuple[bytes, int]]:
        out = []
        while (sample := subscriber.try_recv()) is not None:
            stamp = sample.timestamp
            if stamp is None:
                if topic is not HEARTBEAT:  # the recorder's own heartbeats never pass the router
                    missing_stamp.warning("no-timestamp", f"recorder: samples on {topic.suffix} carry no router "
                                                          "timestamp; receive_time = the sender's stamp")
                out.append((sample.payload.to_bytes(), NO_RECEIVE_TIME))
            else:
                out.append((sample.payload.to_bytes(), stamp.get_time_as_ntp64().as_nanos()))
        return out
    return take


def default_output_path(directory: Path, run_id: str) -> Path:
    return directory / f"handover-{run_id}.rrd"


def run_recorder(profile: Profile, output: Path, config: RecorderConfig | None = None,
                 application_id: str = "handover") -> int:
    """Record the bus into `output` until SIGINT/SIGTERM (settings: `RecorderConfig`)."""
    import zenoh

    config = config or RecorderConfig()
    topics = recorded_topics(config.depth_every)
    with ServiceNode(SERVICE_NAME, profile, clock_role="observer") as node:
        subscribers = {t: node.session.declare_subscriber(t.key(profile.prefix), zenoh.handlers.RingChannel(
            DEPTH_QUEUE_CAPACITY if t is DEPTH else QUEUE_CAPACITY)) for t in topics}
        node.ready()  # alive = listening: nothing may be published before the recorder hears it
        from services.recorder.writer import RecordingWriter  # Rerun, NumPy, PyArrow: after subscribing

        missing_stamp = RateLimitedLog(log, 3600.0)
        sources = {t: channel_source(sub, t, missing_stamp) for t, sub in subscribers.items()}
        writer = RecordingWriter(output, profile.prefix, config, application_id=application_id, sources=sources)
        stats = writer.stats
        log.info("recording", extra=kv(output=str(output), keys=len(topics), depth_every=config.depth_every,
                                       robot_model=config.robot_model, flush_period_s=config.flush_period_s))
        try:
            consume(writer, node.stop_event)
            settle(writer.collect)
        finally:
            writer.collect()
            writer.sources = {}  # the channels go with their subscribers
            for subscriber in subscribers.values():
                subscriber.undeclare()
            finalised = close_and_finalise(writer)
            flush_ms = sorted(1e3 * s for s in stats.flush_s) or [0.0]
            log.info("recording closed", extra=kv(
                output=str(output), messages=sum(stats.logged.values()), rejected=stats.rejected,
                max_pending=stats.max_pending, unknown_keys=stats.unknown.count, flushes=len(stats.flush_s),
                flush_ms_median=round(flush_ms[len(flush_ms) // 2], 2),
                flush_ms_p99=round(flush_ms[min(len(flush_ms) - 1, int(0.99 * len(flush_ms)))], 2),
                finalised=finalised is not None,
                **({} if finalised is None else {"chunks": finalised.kept.chunks,
                                                 "finalise_s": round(finalised.seconds, 2)})))
    return 0


def close_and_finalise(writer):
    """Close the writer's file, then give it its footer (`finalise`); returns the
    `FinaliseReport`, or None with a warning naming the command that finishes the job when
    finalising failed or a second SIGINT/SIGTERM interrupted it (the launcher's SIGTERM comes
    `term_timeout_s` after its SIGINT): the file is then complete, without footer. Every
    message the writer wrote must be in the finalised file."""
    from services.recorder.errors import RecorderError
    from services.recorder.finalise import finalise

    writer.close(finalise=False)  # everything written and flushed; a second signal is ignored here
    try:
        with _signals_interrupt():
            report = finalise(writer.output)
    except (RecorderError, FinaliseInterrupted) as exc:
        log.warning("recording not finalised (complete, but without the footer `rerun rrd verify` "
                    "needs): %s; run: handover-recorder finalise %s", exc, writer.output)
        return None
    written = {key: n for key, n in writer.stats.logged.items() if n}
    if report.kept.bus_messages() != written:
        log.warning("finalised recording differs from what was written", extra=kv(
            output=str(writer.output), written=written, finalised=report.kept.bus_messages()))
    return report


class FinaliseInterrupted(Exception):
    """A SIGINT/SIGTERM arrived while the recording was being finalised."""


@contextlib.contextmanager
def _signals_interrupt():
    """While inside: SIGINT/SIGTERM raise `FinaliseInterrupted` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, _frame: object) -> None:
        raise FinaliseInterrupted(f"{signal.Signals(signum).name} received while finalising")

    previous = {sig: signal.signal(sig, interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
