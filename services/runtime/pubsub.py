"""Typed publish and subscribe on one Zenoh session: decode at the edge, bounded queues,
per-publisher headers (see `services.runtime.node.ServiceNode`, which makes these).

Freshness is judged by local receive time (`time.monotonic()`), never by the sender's stamp;
except on the simulation clock (`services.runtime.clock`), where a message's time is its
sender's simulated stamp and a reader at time t takes in only what was stamped before t.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

import zenoh

from bus_schema import MAX_PAYLOAD_BYTES, Topic, decode, encode_for
from bus_schema.codec import DecodeError
from bus_schema.messages import Message
from bus_schema.topics import sender_of_key
from services.runtime.faults import FaultyPut
from services.runtime.logs import RateLimitedLog
from services.runtime.stamps import SENDER_CLOCK, SenderClock

if TYPE_CHECKING:
    from services.runtime.node import ServiceNode

log = logging.getLogger(__name__)

#: Simulation clock: a ring channel holds at least this many samples, so that messages stamped
#: at the reader's own step, held back until its next one, do not push out older ones.
SIM_MIN_RING = 64

M = TypeVar("M", bound=Message)


@dataclass(frozen=True)
class Received(Generic[M]):
    """A decoded message and its local receive time (`time.monotonic()`, s; on the simulation
    clock: the simulated time it was sent at)."""

    msg: M
    rx_monotonic: float


@dataclass
class SubscriptionStats:
    """Counters of one subscription.

    Attributes:
        received: payloads that arrived.
        accepted: payloads that decoded.
        rejected: payloads dropped because they did not decode.
        seq_gaps: messages missed according to the publishers' sequence numbers.
        overflowed: accepted messages dropped because the queue was full.
        duplicates: exact copies (source, seq, stamp) dropped: a waking subscription gets
            some twice across a switch between resting and waking (`wakes_loop`).
    """

    received: int = 0
    accepted: int = 0
    rejected: int = 0
    seq_gaps: int = 0
    overflowed: int = 0
    duplicates: int = 0


class TypedSubscription(Generic[M]):
    """Decode-at-the-edge subscription to one topic.

    Each payload is decoded with the topic's typed decoder; a payload that does not decode is
    counted, logged (rate-limited) and dropped. Decoded messages go to a bounded queue read by
    the service thread with `latest()` or `drain()`.

    Two ways in, chosen by `wake`:
    - ``wake=True``: a Zenoh callback decodes each sample on Zenoh's thread, queues it and wakes
      the node's `wait()` (for the few keys a loop must react to at once: stops, releases).
      A loop may rest such a subscription (`wakes_loop = False`, the gripper while it does not
      release): its samples then wait in a ring channel as with ``wake=False``, and no Python
      runs per sample until it wakes again. With `wake_if`, a sample wakes the loop only when
      ``wake_if(msg)`` is true (it is still decoded and queued either way; an exact copy that
      is dropped wakes nothing): the gripper wakes for a supervisor state only when the
      episode or the grip request changed. (What waited in the ring of a rested subscription
      is taken in by the reader, not judged by it.)
    - ``wake=False``: samples wait in a Zenoh ring channel (bounded, oldest dropped, no Python
      and no GIL on Zenoh's thread) and are decoded by the reader when it calls `latest()`,
      `drain()`, `age_s()` or `stats`. For streams a loop reads at its own tick this removes a
      GIL hand-over per message; the receive time (`rx_monotonic`) is then the time the reader
      took the sample in, at most one of its ticks after arrival.
    """

    def __init__(self, node: ServiceNode, topic: Topic, queue_size: int, wake: bool = True,
                 wall_time: bool = False, wake_if: Callable[[M], bool] | None = None) -> None:
        self.topic = topic
        #: Runs on Zenoh's thread for each accepted sample of a waking subscription: whether
        #: it wakes the loop (None: every one; an exception in it wakes the loop).
        self._wake_if = wake_if
        # The simulation clock reads every stream at its steps: no callbacks (`_release`).
        wake = wake and not (node.clock.is_sim and node.clock_role != "observer" and not wall_time)
        self.wake = wake
        self._wakes_loop = wake
        #: ``wake=True`` at rest: the ring channel its samples wait in (see `wakes_loop`).
        self._resting: zenoh.Subscriber[Any] | None = None
        #: Once it has rested: the exact keys of recent messages, to drop copies.
        self._seen: deque[tuple[str, int, int]] | None = None
        self._seen_set: set[tuple[str, int, int]] = set()
        self.key = topic.key(node.profile.prefix)
        self._stats = SubscriptionStats()
        self._node = node
        self._queue: deque[Received[M]] = deque(maxlen=queue_size)
        self._latest: Received[M] | None = None
        self._last_seq: dict[str, int] = {}
        self._bad_log = RateLimitedLog(log, 1.0)
        self._pump_lock = threading.Lock()
        # On the simulation clock (and not `wall_time`, as heartbeats are, nor an observer's:
        # the launcher's, the recorder's): messages wait in `_held` until the reader's time is
        # past their stamp (`_release`).
        paced = node.clock.is_sim and node.clock_role != "observer"
        self._sim_clock = node.clock if paced and not wall_time else None
        self._held: list[Received[M]] = []
        ring_size = queue_size if self._sim_clock is None else max(queue_size, SIM_MIN_RING)
        # A callback subscriber (Subscriber[None]) or a ring channel's (try_recv): Any covers both.
        self._subscriber: zenoh.Subscriber[Any]
        if wake:
            self._subscriber = node.session.declare_subscriber(self.key, self._on_sample)
        else:
            self._subscriber = node.session.declare_subscriber(self.key, zenoh.handlers.RingChannel(ring_size))

    # Runs on a Zenoh thread: decode, count, enqueue, notify. Nothing else. (A subscription
    # paced by the simulation clock never wakes: it reads a ring channel, `__init__`.)
    def _on_sample(self, sample: zenoh.Sample) -> None:
        rx = time.monotonic()
        with self._pump_lock:
            before = self._latest
            accepted = self._accept(sample, rx)
            latest = self._latest
        if accepted and self._wakes_loop and self._wakes_for(None if latest is before else latest):
            self._node._notify()

    def _wakes_for(self, item: Received[M] | None) -> bool:
        """Whether an accepted sample wakes the loop (`wake_if`; Zenoh's thread): `item`, the
        message it queued, None when it queued none (an exact copy, dropped)."""
        if self._wake_if is None:
            return True
        if item is None:
            return False
        try:
            return bool(self._wake_if(item.msg))
        except Exception:  # noqa: BLE001 - never into Zenoh's thread; a doubtful sample wakes
            return True

    @property
    def wakes_loop(self) -> bool:
        """``wake=True``: whether each sample wakes the loop now."""
        return self._wakes_loop

    @wakes_loop.setter
    def wakes_loop(self, on: bool) -> None:
        """Rest a waking subscription (False: its samples wait in a ring channel, read at the
        loop's next tick, no Python per sample) or wake it again (True: what waited is taken in
        first). Nothing is lost across a switch; a sample that reached both ways counts once.
        Call from the reader's thread; a no-op for ``wake=False``."""
        on = bool(on)
        if not self.wake or on == self._wakes_loop:
            return
        session, size = self._node.session, self._queue.maxlen or 1
        if self._seen is None:
            self._seen = deque(maxlen=2 * size)
        if on:  # the callback first, then what waited (samples in between arrive both ways);
            # the lock keeps the callback from taking a newer sample before the older ones
            with self._pump_lock:
                self._subscriber = session.declare_subscriber(self.key, self._on_sample)
                self._wakes_loop = True
                ring, self._resting = self._resting, None
                if ring is not None:
                    self._drain_ring(ring)
            if ring is not None:
                _undeclare(ring)
        else:  # the ring first, then no more callbacks
            self._resting = session.declare_subscriber(self.key, zenoh.handlers.RingChannel(size))
            self._wakes_loop = False
            callback, self._subscriber = self._subscriber, self._resting
            _undeclare(callback)

    def _drain_ring(self, ring: Any) -> None:
        """Take in every sample waiting in `ring` (pump lock held)."""
        try_recv = ring.try_recv
        while True:
            try:
                sample = try_recv()
            except Exception:  # noqa: BLE001 - shutdown: the session closed under us
                return
            if sample is None:
                return
            self._accept(sample, time.monotonic())

    def _pump(self) -> None:
        """Take in what waits in the ring channel (``wake=False``, or a waking subscription at
        rest; reader's thread), and on the simulation clock what was stamped before now (a
        subscription paced by it never wakes)."""
        if self.wake and self._resting is None:
            return
        with self._pump_lock:
            self._drain_ring(self._subscriber)
            if self._sim_clock is not None:
                self._release()

    def _accept(self, sample: zenoh.Sample, rx: float) -> bool:
        """Decode, count and queue one sample; False when it was dropped."""
        stats = self._stats
        stats.received += 1
        try:
            size = len(sample.payload)
            if size > MAX_PAYLOAD_BYTES:  # refused before it is copied out of Zenoh
                raise DecodeError(f"payload of {size} bytes exceeds the {MAX_PAYLOAD_BYTES}-byte cap")
            msg = decode(self.topic, sample.payload.to_bytes())
            if self.topic.per_sender and msg.source != (sender := sender_of_key(str(sample.key_expr))):
                raise DecodeError(f"source {msg.source!r} published on {sender!r}'s key")
        except DecodeError as exc:
            stats.rejected += 1
            self._bad_log.warning(
                self.key,
                f"dropped undecodable payload on {self.key}: {exc}",
                rejected=stats.rejected,
            )
            return False
        except Exception as exc:  # noqa: BLE001 - never let anything escape into Zenoh's thread
            stats.rejected += 1
            self._bad_log.warning(self.key, f"dropped payload on {self.key}: {exc!r}")
            return False
        if self._sim_clock is not None:
            self._held.append(Received(msg, msg.stamp_ns / 1e9))
            return True
        self._take(Received(msg, rx))
        return True

    def _release(self) -> None:
        """Simulation clock (pump lock held): take in the held messages stamped before now, in
        (stamp, sender, seq) order, whatever order they arrived in."""
        held = self._held
        if not held:
            return
        assert self._sim_clock is not None
        now_ns = self._sim_clock.now_ns()
        due = [item for item in held if item.msg.stamp_ns < now_ns]
        if not due:
            return
        self._held = [item for item in held if item.msg.stamp_ns >= now_ns]
        due.sort(key=lambda item: (item.msg.stamp_ns, item.msg.source, item.msg.seq))
        for item in due:
            self._take(item)

    def _take(self, item: Received[M]) -> None:
        """Count and queue one decoded message (an exact copy of a recent one is dropped)."""
        stats, msg = self._stats, item.msg
        if self._seen is not None:
            key = (msg.source, msg.seq, msg.stamp_ns)
            if key in self._seen_set:
                stats.duplicates += 1
                return
            if len(self._seen) == self._seen.maxlen:
                self._seen_set.discard(self._seen[0])
            self._seen.append(key)
            self._seen_set.add(key)
        last = self._last_seq.get(msg.source)
        if last is not None and msg.seq > last + 1:
            stats.seq_gaps += msg.seq - last - 1
        self._last_seq[msg.source] = msg.seq
        stats.accepted += 1
        if len(self._queue) == self._queue.maxlen:
            stats.overflowed += 1
        self._queue.append(item)
        self._latest = item

    @property
    def stats(self) -> SubscriptionStats:
        """Counters of this subscription (takes waiting samples in first)."""
        self._pump()
        return self._stats

    def latest(self) -> Received[M] | None:
        """The most recent message received so far (None before the first)."""
        self._pump()
        return self._latest

    def drain(self) -> list[Received[M]]:
        """All messages received since the last drain, oldest first."""
        self._pump()
        out = []
        queue = self._queue
        while queue:
            try:
                out.append(queue.popleft())
            except IndexError:
                break
        return out

    def age_s(self, now_monotonic: float | None = None) -> float:
        """Seconds since the last accepted message (inf before the first)."""
        self._pump()
        if self._latest is None:
            return float("inf")
        if now_monotonic is not None:
            now = now_monotonic
        else:
            now = time.monotonic() if self._sim_clock is None else self._sim_clock.now_s()
        return now - self._latest.rx_monotonic

    def undeclare(self) -> None:
        _undeclare(self._subscriber)
        if self._resting is not None and self._resting is not self._subscriber:
            _undeclare(self._resting)


def _undeclare(subscriber: Any) -> None:
    try:
        subscriber.undeclare()
    except Exception:  # noqa: BLE001 - best-effort close: already closed with the session
        pass


class TypedPublisher(Generic[M]):
    """Publisher of one topic; fills the header (per-publisher `seq`, `stamp_ns` from the
    process's `SENDER_CLOCK`, `source`)."""

    def __init__(self, node: ServiceNode, topic: Topic, stamps: SenderClock | None = None) -> None:
        """`stamps`: the stamp source (default: the process's `SENDER_CLOCK`; a publisher
        paced by the wall clock on the simulation clock, a heartbeat's, has its own, so that
        how often it sends never shifts the other publishers' stamps)."""
        self.topic = topic
        self._stamps = SENDER_CLOCK if stamps is None else stamps
        self.key = topic.sender_key(node.name, node.profile.prefix)
        self._source = node.name
        self._seq = 0
        # An event (a goal, a stop, a release) gets the simulation clock an event step.
        self._clock = node.clock
        self._is_event = topic.delivery == "safety" and topic.nominal_rate_hz == 0
        self._lock = threading.Lock()
        if node.clock.is_sim:
            # The simulation clock: one priority, never dropped, so that on every link a clock
            # message follows whatever its sender sent before it (`services.runtime.clock`).
            cc, prio = zenoh.CongestionControl.BLOCK, zenoh.Priority.DATA
        elif topic.delivery == "safety":
            cc, prio = zenoh.CongestionControl.BLOCK, zenoh.Priority.REAL_TIME
        else:
            cc, prio = zenoh.CongestionControl.DROP, zenoh.Priority.DATA
        self._publisher = node.session.declare_publisher(
            self.key, congestion_control=cc, priority=prio
        )
        self._send: Any = self._publisher.put
        rule = node.fault_rules.get(topic.suffix)
        if rule is not None:
            self._send = FaultyPut(self._publisher.put, rule)
            log.warning("fault injection on %s: %s=%g", topic.suffix, rule.kind, rule.value)

    def next_header(self) -> dict[str, Any]:
        """Header fields for the next message (advances `seq`)."""
        with self._lock:
            seq = self._seq
            self._seq += 1
        return {"seq": seq, "stamp_ns": self._stamps.now_ns(), "source": self._source}

    def put(self, **fields: Any) -> M:
        """Build a message of the topic's type from `fields` plus a fresh header; publish it.

        Returns:
            The message that was published.
        """
        msg = self.topic.type(**self.next_header(), **fields)
        self._send(encode_for(self.topic, msg))
        if self._is_event:
            self._clock.note_event()
        return msg  # type: ignore[return-value]

    def put_message(self, msg: M) -> None:
        """Publish a message built elsewhere (its header is sent as is)."""
        self._send(encode_for(self.topic, msg))
        if self._is_event:
            self._clock.note_event()

    def put_raw(self, payload: bytes) -> None:
        """Publish raw bytes on this key (fault injection and fuzzing only)."""
        self._send(payload)

    def undeclare(self) -> None:
        if isinstance(self._send, FaultyPut):
            self._send.close()
        try:
            self._publisher.undeclare()
        except Exception:  # noqa: BLE001 - best-effort close: already closed with the session
            pass
