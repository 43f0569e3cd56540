"""ServiceNode: one Zenoh session per service, liveliness, heartbeat, shutdown; its typed
publishers and subscriptions are in `services.runtime.pubsub`, its heartbeat thread in
`services.runtime.heartbeat`.

Rules this module enforces (NOTES.md, Zenoh):
- every session uses the profile's loopback-only config (multicast and gossip off);
- callbacks only decode and enqueue: no blocking work and no Zenoh calls inside them;
- the session is closed from the main thread, never from a callback, and no lock a callback
  needs is held while closing;
- safety keys publish with congestion control BLOCK and priority REAL_TIME, state keys with
  DROP and DATA.

Freshness is judged by local receive time (`time.monotonic()`), never by the sender's stamp.
"""

from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import zenoh

from bus_schema import Topic, alive_key
from bus_schema.topics import HEARTBEAT
from services.runtime.clock import WALL_GRID_PHASE_S, SimClock, WallClock, grid_phase_s
from services.runtime.clock_owner import ClockOwner, make_clock
from services.runtime.errors import BusError
from services.runtime.faults import rules_for
from services.runtime.heartbeat import (
    HEARTBEAT_PERIOD_S,
    MULTIHOST_HEARTBEAT_PERIOD_S,
    Heartbeat,
    heartbeat_period_s,
)
from services.runtime.logs import kv
from services.runtime.loop import RateLoop
from services.runtime.profile import Profile
from services.runtime.signals import SignalRelay
from services.runtime.pubsub import Received, SubscriptionStats, TypedPublisher, TypedSubscription
from services.runtime.session import open_session
from services.runtime.stamps import SENDER_CLOCK, SenderClock

__all__ = ["HEARTBEAT_PERIOD_S", "MULTIHOST_HEARTBEAT_PERIOD_S", "Received", "ServiceNode", "SubscriptionStats",
           "TypedPublisher", "TypedSubscription", "heartbeat_period_s", "open_session"]

#: Simulation clock: a loop's deadline counts as reached this close before it, s (whole-ns
#: times against the grid's float sums).
SIM_TOLERANCE_S = 1e-6


log = logging.getLogger(__name__)


class ServiceNode:
    """A service's presence on the bus.

    Use as a context manager in the service's main thread::

        with ServiceNode("bridge", profile) as node:
            pub = node.publisher(topics.JOINT_STATE)
            sub = node.subscribe(topics.JOINT_COMMAND)
            for tick in node.loop(100.0):
                ...

    Entering opens the session (client mode, connecting to the profile's router) and installs
    SIGINT/SIGTERM handlers that request shutdown. The liveliness token
    ``<prefix>/alive/<name>`` is declared by `ready()`, which a service calls once it has
    declared its subscriptions (and which its first `wait()` or `loop()` calls otherwise): alive
    means listening. Leaving undeclares everything and closes the session, from this thread.

    A subscription wakes `wait()` only if declared with ``wake=True`` (the default): high-rate
    streams that a loop reads at its own tick (``latest()``, ``drain()``) should pass
    ``wake=False`` so that each message does not cost the service a thread switch.

    A heartbeat thread (`services.runtime.heartbeat`) beats while the process runs
    (``heartbeat=False``: none, the launcher's own node); a stalled main loop shows in the
    freshness of the service's own data streams instead. `HANDOVER_FAULTS` rules for this service
    (`services.runtime.faults`) delay or drop its publications (fault tests only).

    `clock` is the stack's clock (`services.runtime.clock`): the wall clock, or on a profile
    run on the simulation clock the bridge's simulation's. There `clock_role` says what this
    node is to it: ``owner`` (the bridge's simulation grants the steps), ``participant`` (the
    default: its loops and `wait` are paced by the clock, which waits for it) or ``observer``
    (its loops, waits and readings stay on the wall clock, it gets no steps and nobody waits for
    it; what it sends is stamped near 0, so readers take it in at their next step: the recorder,
    the launcher, tools).
    """

    def __init__(
        self,
        name: str,
        profile: Profile,
        *,
        mode: str = "client",
        connect_timeout_s: float = 10.0,
        install_signal_handlers: bool = True,
        clock_role: str = "participant",
        heartbeat: bool = True,
    ) -> None:
        self.name = name
        self._sends_heartbeats = heartbeat
        self.profile = profile
        self.mode = mode
        self.connect_timeout_s = connect_timeout_s
        self.stop_event = threading.Event()
        self._install_signal_handlers = install_signal_handlers
        self._wake = threading.Condition()
        self._new_data = False
        self._subscriptions: list[TypedSubscription[Any]] = []
        self._publishers: list[TypedPublisher[Any]] = []
        #: The publisher of each topic (by suffix) and whether it has its own stamps (`publisher`).
        self._publishers_by_key: dict[str, tuple[TypedPublisher[Any], bool]] = {}
        self._session: zenoh.Session | None = None
        self._token: Any = None
        self._signals = SignalRelay(self._on_signal, name=f"{name} signals")
        self.loops: list[RateLoop] = []
        self.fault_rules = rules_for(name, enabled=profile.fault_injection)
        self._heartbeat: Heartbeat | None = None
        #: Period of this service's heartbeat, s (`heartbeat_period_s`).
        self.heartbeat_period_s = heartbeat_period_s(profile)
        #: The stack's clock (`services.runtime.clock`): loops, time-outs and freshness read it.
        self.clock_role = clock_role
        self.clock: WallClock | SimClock | ClockOwner = make_clock(name, clock_role, profile)

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> ServiceNode:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def open(self) -> None:
        if self._install_signal_handlers:
            self._signals.install()  # main thread only; acted on in the relay's thread (`signals`)
        try:
            self._session = open_session(self.profile, self.mode, self.connect_timeout_s, user=self.name)
        except BaseException:
            self._signals.restore()
            raise
        if not isinstance(self.clock, WallClock):
            self.clock.attach(self)
            SENDER_CLOCK.follow(self.clock.stamp_ns)
        if self._sends_heartbeats:  # the launcher's own node is watched by no one: it sends none
            self._heartbeat = Heartbeat(self.name, self.publisher(HEARTBEAT, own_stamps=True),
                                        self.heartbeat_period_s, self.stop_event)
            self._heartbeat.start()
        log.info(
            "%s connected to the bus",
            self.name,
            extra=kv(endpoint=self.profile.endpoint, prefix=self.profile.prefix),
        )

    def close(self) -> None:
        """Undeclare subscriptions, publishers and the token, then close the session."""
        self.stop_event.set()
        self.clock.close()
        if not isinstance(self.clock, WallClock):
            SENDER_CLOCK.follow(time.time_ns)  # the process's stamps go back to the wall clock
        for sub in self._subscriptions:
            sub.undeclare()
        for pub in self._publishers:
            pub.undeclare()
        self._publishers_by_key.clear()
        if self._token is not None:
            try:
                self._token.undeclare()
            except Exception:  # noqa: BLE001 - best-effort close: the session may be gone already
                pass
            self._token = None
        if self._session is not None:
            try:
                self._session.close()
            except Exception as exc:  # noqa: BLE001 - best-effort close, said once
                log.warning("closing the Zenoh session failed: %s", exc)
            self._session = None
        self._signals.restore()

    def ready(self) -> None:
        """Declare the liveliness token: call once every subscription is declared (alive means
        listening). Idempotent; the first `wait()` or `loop()` calls it too."""
        if self._token is None:
            self._token = self.session.liveliness().declare_token(alive_key(self.name, self.profile.prefix))

    @property
    def is_ready(self) -> bool:
        """True once the liveliness token is declared."""
        return self._token is not None

    def _on_signal(self, signum: int) -> None:
        """SIGINT/SIGTERM, in the relay's thread (never the signal handler: it may take locks)."""
        log.info("%s received %s, shutting down", self.name, signal.Signals(signum).name)
        self.request_stop()

    def request_stop(self) -> None:
        """Ask the service's loops to end (thread-safe; not from a signal handler: it takes locks)."""
        self.stop_event.set()
        self._notify()
        if not isinstance(self.clock, WallClock):
            self.clock.wake()

    @property
    def should_stop(self) -> bool:
        return self.stop_event.is_set()

    @property
    def session(self) -> zenoh.Session:
        if self._session is None:
            raise BusError(f"{self.name}: the bus session is not open")
        return self._session

    # ------------------------------------------------------------------ pub/sub
    def publisher(self, topic: Topic, own_stamps: bool = False) -> TypedPublisher[Any]:
        """The node's publisher of `topic`: one per topic, made at the first call, so that every
        part of a service sends through one numbering (two publishers of one source would both
        count from 0, and readers that take each (source, seq) once, the recorder, would drop
        one's messages). `own_stamps`: its stamps come from a clock of its own that follows the
        stack's (for a publisher whose sending does not follow the stack's clock, as heartbeats
        on the simulation clock: its messages must not shift the others' stamps).

        Not thread-safe: a service makes its publishers from one thread (its main one).

        Raises:
            BusError: `topic`'s publisher was made already with the other `own_stamps`.
        """
        made = self._publishers_by_key.get(topic.suffix)
        if made is not None:
            if made[1] != own_stamps:
                raise BusError(f"{self.name}: {topic.suffix} already has a publisher with own_stamps="
                               f"{made[1]}; one topic, one publisher")
            return made[0]
        stamps = None
        if own_stamps:
            stamps = SenderClock()
            if not isinstance(self.clock, WallClock):
                stamps.follow(self.clock.now_ns)
        pub: TypedPublisher[Any] = TypedPublisher(self, topic, stamps)
        self._publishers.append(pub)
        self._publishers_by_key[topic.suffix] = (pub, own_stamps)
        return pub

    def subscribe(self, topic: Topic, queue_size: int = 256, wake: bool = True,
                  wall_time: bool = False, wake_if: Callable[[Any], bool] | None = None) -> TypedSubscription[Any]:
        """Subscribe to `topic`; `wake=False`: its messages do not wake `wait()`. `wall_time`:
        on the simulation clock too, its messages are taken in as they arrive and timed on the
        local monotonic clock (heartbeats: liveness is a wall-clock matter). `wake_if`: a
        message wakes `wait()` only when ``wake_if(msg)`` is true (called on Zenoh's thread)."""
        sub: TypedSubscription[Any] = TypedSubscription(self, topic, queue_size, wake, wall_time, wake_if)
        self._subscriptions.append(sub)
        return sub

    def wake_up(self) -> None:
        """Wake `wait()` now (thread-safe; cheap enough for a Zenoh callback)."""
        self._notify()

    def _notify(self) -> None:
        with self._wake:
            self._new_data = True
            self._wake.notify_all()

    def heartbeat(self) -> None:
        """Send the heartbeat now if the last one is at least a period old (any thread; the
        heartbeat thread sends them anyway, so a loop need not call this)."""
        if self._heartbeat is not None:
            self._heartbeat.beat_if_due()

    def wait(self, timeout_s: float) -> bool:
        """Block until any subscription has new data, shutdown, or `timeout_s` passes.

        On the simulation clock: done with the current time; returns at the next step that
        names this service (at most `timeout_s` of simulated time later).

        Returns:
            True when new data arrived since the last call (simulation clock: a step came).
        """
        if self._token is None:
            self.ready()
        if self._paced_by_sim_clock:
            return self._sim_clock.wait(timeout_s)
        with self._wake:
            if not self._new_data and not self.stop_event.is_set():
                self._wake.wait(timeout_s)
            got = self._new_data
            self._new_data = False
        return got

    def loop(self, rate_hz: float) -> Iterator[int]:
        """A fixed-rate loop (see `RateLoop`) that ends on shutdown (declares the liveliness
        token first if `ready()` was not called)."""
        yield from self.rate_loop(rate_hz)

    def rate_loop(self, rate_hz: float, urgent: Callable[[], bool] | None = None,
                  urgent_per_period: int | None = 1) -> RateLoop:
        """The `RateLoop` at `rate_hz` (Hz) behind `loop`, for a caller that reads its period or
        stats. `urgent`: asked whenever a subscription with ``wake=True`` (or `wake_up`) wakes
        the loop; True runs an extra tick at once, at most `urgent_per_period` of them between
        two grid ticks (None: no limit). On the wall clock the grid is the host's shared one
        (`WALL_GRID_PHASE_S`: the first tick waits for its first point, and a `rest_until`
        deadline moves to the nearest point), so every process's loops wake together.
        Declares the liveliness token first if `ready()` was not called."""
        self.ready()
        name = f"{self.name} {rate_hz:g} Hz loop"
        if not self._paced_by_sim_clock:
            loop = RateLoop(rate_hz, self.stop_event, name=name, urgent=urgent,
                            wake_source=self.wait if urgent is not None else None, urgent_per_period=urgent_per_period,
                            align_phase_s=WALL_GRID_PHASE_S, rest_on_grid=True)
        else:  # the simulation clock: a grid from time 0, every step through the clock
            clock = self._sim_clock
            if isinstance(clock, ClockOwner):
                clock.wait_for_start()  # its first tick, at 0, must reach every participant
            loop = RateLoop(rate_hz, self.stop_event, name=name, clock=clock.now_s, wait=clock.wait,
                            urgent=urgent, wake_source=clock.wait if urgent is not None else None,
                            urgent_per_period=urgent_per_period, align_phase_s=grid_phase_s(self.name),
                            tolerance_s=SIM_TOLERANCE_S)
        self.loops.append(loop)
        return loop

    @property
    def _sim_clock(self) -> SimClock | ClockOwner:
        """The simulation clock (only where `_paced_by_sim_clock`)."""
        assert not isinstance(self.clock, WallClock)
        return self.clock

    @property
    def _paced_by_sim_clock(self) -> bool:
        """Loops and waits go through the simulation clock (an observer's stay on the wall clock)."""
        return not isinstance(self.clock, WallClock) and self.clock_role != "observer"

    def stats(self) -> dict[str, Any]:
        """Counters of every subscription and loop, for logs and tests."""
        return {
            "subscriptions": {s.key: vars(s.stats).copy() for s in self._subscriptions},
            "loops": [vars(lp.stats).copy() for lp in self.loops],
        }

