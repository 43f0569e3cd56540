"""The simulation clock's owner: the bridge's simulation grants the steps (`ClockBarrier` on the
bus). See `services.runtime.clock` for the protocol.

The owner's loop calls `wait(timeout_s)` like any participant: it grants steps to the others
until time reaches its own deadline (or an event step), then returns and runs its tick at that
time, concurrently with the participants due at the same step. While it waits for an answer it
asks the kernel, every `STOPPED_CHECK_S` of wall time, whether the quiet participant's process
is stopped or gone (SIGSTOP, a crash): then it stops waiting for it, so that the stack's
watchdogs (which judge liveness on the wall clock) see the fault instead of a frozen clock.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from typing import TYPE_CHECKING, Any

import zenoh

from bus_schema import decode, encode_for, topics
from bus_schema.messages import ClockGrant
from bus_schema.topics import sender_of_key
from services.runtime.clock import (CLOCK_ENV, ClockError, SimClock, WallClock, clock_source, grant_key,
                                    seconds_to_ns)
from services.runtime.clock_barrier import ClockBarrier, Step
from services.runtime.liveliness import LivelinessWatcher
from services.runtime.logs import RateLimitedLog
from services.runtime.sched import read_state
from services.runtime.stamps import SenderClock

if TYPE_CHECKING:
    from services.runtime.node import ServiceNode
    from services.runtime.profile import Profile

log = logging.getLogger(__name__)

#: How often (wall s) the owner asks the kernel about a participant it has waited for.
STOPPED_CHECK_S = 0.05
#: A participant quiet for this long (wall s) while running is said in the log (rate-limited).
SLOW_REPORT_S = 5.0
#: The owner waits for the expected participants' first answers at most this long (wall s).
START_TIMEOUT_S = 60.0


def expected_participants(profile_services: list[str], owner: str, override: str | None) -> frozenset[str]:
    """The participants the clock waits for: `override` (comma-separated names, from
    ``HANDOVER_CLOCK_PARTICIPANTS``, which the launcher sets to the services it starts) or every
    service of the profile except the owner and the recorder (which paces nothing)."""
    if override is not None:
        names = {n.strip() for n in override.split(",") if n.strip()}
    else:
        names = set(profile_services)
    return frozenset(names - {owner, "recorder"})


def make_clock(name: str, role: str, profile: Profile) -> WallClock | SimClock | ClockOwner:
    """The clock of service `name` under `profile` (`clock_source`): the wall clock, or on the
    simulation clock its `role`'s: ``owner`` (this module's `ClockOwner`, waiting for the
    participants of ``HANDOVER_CLOCK_PARTICIPANTS`` or the profile), ``participant`` or
    ``observer`` (a `SimClock`).

    Raises:
        ValueError: an unknown role.
    """
    if role not in ("participant", "owner", "observer"):
        raise ValueError(f"clock_role must be participant, owner or observer, not {role!r}")
    if clock_source(profile.clock) != "sim":
        return WallClock()
    if role == "owner":
        override = os.environ.get(CLOCK_ENV + "_PARTICIPANTS")
        return ClockOwner(name, expected_participants([s.name for s in profile.services], name, override))
    return SimClock(name)


class ClockOwner:
    """The owner's clock: same interface as `SimClock` (`now_s`, `wait`, `note_event`, `close`).

    Args:
        name: the owner's service name.
        expected: the participants to wait for before the first step.
    """

    is_sim = True

    def __init__(self, name: str, expected: frozenset[str]) -> None:
        self.name = name
        self.barrier = ClockBarrier(expected)
        self._cond = threading.Condition()
        self._grant_pubs: dict[str, Any] = {}  # participant → its grant key's publisher
        self._session: Any = None
        self._prefix = ""
        self._stamps = SenderClock()
        self._stopping: threading.Event | None = None
        self._watcher: LivelinessWatcher | None = None
        self._slow_log = RateLimitedLog(log, SLOW_REPORT_S)
        self._started_wall_s: float | None = None  # when it began waiting for the participants
        self._first_step_wall_s: float | None = None
        #: Steps granted to each participant (said in the log at exit).
        self.grants: dict[str, int] = {}
        #: Wall time spent waiting for the participants' answers, s (said in the log at exit).
        self.waited_s = 0.0
        #: Per participant: the wall time from grant to answer summed over its steps, s, and how
        #: many steps it answered last (the participants on the clock's critical path).
        self.answer_s: dict[str, float] = {}
        self.last_to_answer: dict[str, int] = {}
        self._granted_wall_s = 0.0

    def attach(self, node: ServiceNode) -> None:
        """Grant steps on `node`'s bus and take the participants' answers and liveliness."""
        self._stopping = node.stop_event
        self._session, self._prefix = node.session, node.profile.prefix
        self._stamps.follow(self.now_ns)
        node.session.declare_subscriber(topics.CLOCK_READY.key(node.profile.prefix), self._on_ready)
        self._watcher = LivelinessWatcher(node.session, node.profile.prefix, on_change=self._on_liveliness)

    # ------------------------------------------------------------------ Zenoh threads
    def _on_ready(self, sample: Any) -> None:
        try:
            msg = decode(topics.CLOCK_READY, sample.payload.to_bytes())
            if msg.source != sender_of_key(str(sample.key_expr)):  # one login cannot answer for another
                raise ValueError(f"source {msg.source!r} on {sample.key_expr}")
        except Exception as exc:  # noqa: BLE001 - a malformed answer is ignored (the sender answers again)
            self._slow_log.warning("bad answer", f"simulation clock: answer ignored: {exc}")
            return
        with self._cond:
            barrier = self.barrier
            if not barrier.ready(msg.source, msg.done_ns, msg.next_ns, events=msg.events, leaving=msg.leaving,
                                 pid=msg.pid):
                self._slow_log.warning(msg.source, f"simulation clock: {msg.source} is not a participant of this run "
                                                   f"(expected: {', '.join(sorted(barrier.expected))}): ignored")
                return
            if msg.source in self.grants:
                self.answer_s[msg.source] = self.answer_s.get(msg.source, 0.0) + time.monotonic() - self._granted_wall_s
            if not any(p.pending for p in barrier.participants.values()):
                self.last_to_answer[msg.source] = self.last_to_answer.get(msg.source, 0) + 1
                self._cond.notify_all()  # the last answer of the step: one wake of the owner, not one per answer

    def _on_liveliness(self, name: str, alive: bool) -> None:
        if not alive:
            with self._cond:
                self.barrier.excuse(name)
                self._cond.notify_all()

    # ------------------------------------------------------------------ the clock
    def now_ns(self) -> int:
        return self.barrier.now_ns

    def now_s(self) -> float:
        return self.barrier.now_ns / 1e9

    def stamp_ns(self) -> int:
        return self.barrier.now_ns

    def note_event(self) -> None:
        """The owner sent an event: the next step is an event step, as for a participant's."""
        with self._cond:
            self.barrier.event_pending = True

    def wake(self) -> None:
        with self._cond:
            self._cond.notify_all()

    def wait_for_start(self) -> None:
        """Block until every expected participant has answered once (all of them listen), so
        that the owner's first tick, at time 0, reaches every one of them (or until shutdown).

        Raises:
            ClockError: one did not answer within `START_TIMEOUT_S`.
        """
        with self._cond:
            while not self.barrier.started:
                if self._stopping is not None and self._stopping.is_set():
                    return
                self._cond.wait(STOPPED_CHECK_S)
                self._check_quiet(0.0)

    def wait(self, timeout_s: float) -> bool:
        """Grant steps until time reaches ``now + timeout_s`` or an event step; returns True at
        a step of the owner's, False on shutdown."""
        if self._session is None:
            raise ClockError(f"{self.name}: the simulation clock's owner is not attached to a bus session")
        owner_next_ns = self.barrier.now_ns + max(0, seconds_to_ns(timeout_s))
        while True:
            step = self._next_step(owner_next_ns)
            if step is None:
                return False
            self._grant(step)
            if step.owner_due:
                return True

    def _grant(self, step: Step) -> None:
        """Send `step` to each participant it names, on its own key (a step of the owner's
        alone is sent to nobody: a participant's time moves at its next step)."""
        if not step.due:
            return
        payload = encode_for(topics.CLOCK, ClockGrant(seq=step.number, stamp_ns=self._stamps.now_ns(), source=self.name,
                                                      step=step.number, time_ns=step.time_ns, due=list(step.due)))
        self._granted_wall_s = time.monotonic()
        for name in step.due:
            self.grants[name] = self.grants.get(name, 0) + 1
            pub = self._grant_pubs.get(name)
            if pub is None:
                pub = self._grant_pubs[name] = self._session.declare_publisher(
                    grant_key(self._prefix, name), congestion_control=zenoh.CongestionControl.BLOCK,
                    priority=zenoh.Priority.DATA)
            pub.put(payload)

    def _next_step(self, owner_next_ns: int) -> Step | None:
        """The next step once the barrier allows it (None on shutdown)."""
        since_s = time.monotonic()
        with self._cond:
            while True:
                if self._stopping is not None and self._stopping.is_set():
                    return None
                step = self.barrier.next_step(owner_next_ns)
                if step is not None:
                    if self._first_step_wall_s is None:
                        self._first_step_wall_s = time.monotonic()
                    else:
                        self.waited_s += time.monotonic() - since_s
                    return step
                self._cond.wait(STOPPED_CHECK_S)
                self._check_quiet(time.monotonic() - since_s)

    def _check_quiet(self, waited_s: float) -> None:
        """Excuse the awaited participants whose process is stopped or gone (lock held)."""
        barrier = self.barrier
        if not barrier.started:
            if self._started_wall_s is None:
                self._started_wall_s = time.monotonic()
            elif time.monotonic() - self._started_wall_s > START_TIMEOUT_S:
                raise ClockError(f"the simulation clock waited {START_TIMEOUT_S:.0f} s for "
                                 f"{', '.join(barrier.unregistered())}: are they running on the simulation clock?")
            return
        for name in barrier.waiting_for():
            pid = barrier.pid_of(name)
            state = read_state(pid) if pid else None
            if state is None or state in "TZXx":  # not "t": a profiler's or debugger's brief stop
                log.warning("simulation clock: %s is %s: not waiting for it", name,
                            "gone" if state is None else "stopped")
                barrier.excuse(name)
            elif waited_s > SLOW_REPORT_S:
                self._slow_log.warning(name, f"simulation clock: waiting for {name} for {waited_s:.0f} s "
                                             f"(process state {state})")

    def close(self) -> None:
        b = self.barrier
        if self._first_step_wall_s is not None:
            wall_s = time.monotonic() - self._first_step_wall_s
            log.info("simulation clock: %d steps (%d of the owner alone, %d event steps) over %.2f s simulated "
                     "in %.2f s of wall time: %.2f× real time; %d participant(s) excused", b.steps,
                     b.owner_only_steps, b.event_steps, b.now_ns / 1e9, wall_s, b.now_ns / 1e9 / max(wall_s, 1e-9),
                     b.excusals)
            log.info("simulation clock: %.2f s of the %.2f s waiting for answers; per participant: steps "
                     "granted, mean ms from grant to answer, steps answered last: %s", self.waited_s, wall_s,
                     ", ".join(f"{name} {count} {1e3 * self.answer_s.get(name, 0.0) / count:.2f} "
                               f"{self.last_to_answer.get(name, 0)}" for name, count in sorted(self.grants.items())))
        for pub in self._grant_pubs.values():
            try:
                pub.undeclare()
            except Exception:  # noqa: BLE001 - best-effort close: the session may be closing
                pass
        self._grant_pubs.clear()
        if self._watcher is not None:
            self._watcher.undeclare()
            self._watcher = None
