"""The stack's clock: the wall clock, or the simulation clock that the bridge's simulation owns.

On the wall clock (every hardware profile, and a simulation run with ``--clock wall``) a
service's time is `time.monotonic()` and its loops sleep. On the simulation clock (as ROS's
``use_sim_time`` and Gazebo's ``/clock``) the bridge's simulation owns time
(`services.runtime.clock_owner`): it grants steps on ``sim/clock/<participant>`` (`ClockGrant`),
and every service that paces a loop takes part: it runs the work due at a step, then says so on
``sim/clock_ready/<name>`` (`ClockReady`) with the time it next needs. Time moves on only when
every participant due at a step has answered, so the stack runs as fast as its slowest
service allows, faster than real time on a free machine and slower, without a false fault, on a
busy one; and a seed gives the same episode step for step:

- A message is stamped with its sender's simulated time (`SENDER_CLOCK` follows this clock),
  and a reader at time t takes in only messages stamped before t, in (stamp, sender, seq)
  order (`services.runtime.pubsub`), whichever arrived first on the wire.
- Everything a participant sends at a step goes out before its `ClockReady`, and on the
  simulation clock every key is sent at one priority and never dropped (Zenoh keeps the order
  of one priority on a link, not across priorities): on every link a grant follows what was
  sent before it, so what a step sent has arrived everywhere before the next step starts.
- The owner steps at phase 0 of every grid; the other participants' grids are shifted by
  `PARTICIPANT_PHASE_S` (1 ms), so a controller sees the sensor sample of the same 10 ms
  period, as on the wall clock where it is woken by it.
- An event (a goal, a stop, a release: an event topic of delivery ``safety``) makes the owner
  grant every participant a step `EVENT_STEP_NS` (1 µs) later, where loops that wake on events
  on the wall clock run their urgent tick.

Liveness stays on the wall clock: heartbeats are sent and judged in wall time, and the owner
stops waiting for a participant whose process the kernel says is stopped or gone.
"""

from __future__ import annotations

import math
import os
import threading
import time
from typing import TYPE_CHECKING, Any

from bus_schema import topics
from services.runtime.errors import ServiceError

if TYPE_CHECKING:
    from services.runtime.node import ServiceNode

#: The environment variable a launcher sets for its services: ``wall`` or ``sim``.
CLOCK_ENV = "HANDOVER_CLOCK"
#: The clock sources a profile may name (``[clock] source``).
CLOCK_SOURCES = ("wall", "sim")
#: The grid phase of every participant but the owner, s (see the module docstring).
PARTICIPANT_PHASE_S = 0.001
#: How long after a step that sent an event the participants get their event step, ns.
EVENT_STEP_NS = 1_000
#: A participant blocked on the clock looks at its stop event at least this often, s (wall).
STOP_POLL_S = 0.1
#: A participant blocked on the clock repeats its last answer this often, s (wall): before its
#: first step the owner may not have been listening yet, and an owner that excused it (its
#: process was stopped, or restarted) takes it back when it hears it again.
REPEAT_ANSWER_S = 1.0


class ClockError(ServiceError):
    """The simulation clock cannot run as configured (the message says what to check)."""


def seconds_to_ns(time_s: float) -> int:
    """`time_s` (s) as whole ns, rounded to the nearest."""
    return int(round(time_s * 1e9))


class WallClock:
    """The wall clock: `time.monotonic()`, loops sleep."""

    is_sim = False

    @staticmethod
    def now_s() -> float:
        """Local monotonic time, s."""
        return time.monotonic()

    @staticmethod
    def now_ns() -> int:
        """Local monotonic time, ns."""
        return time.monotonic_ns()

    def note_event(self) -> None:
        """An event was sent (nothing to do on the wall clock)."""

    def close(self) -> None:
        """Nothing to release."""


class SimClock:
    """A process's view of the simulation clock: an observer until its first `wait`, a
    participant from then on.

    Time starts at 0 and moves only when the owner grants a step (`on_grant`, called on a
    Zenoh thread). `wait(timeout_s)` says the participant is done with the current time and
    next needs the clock `timeout_s` later, then blocks until a step names it: at that time,
    or earlier at an event step.

    Args:
        name: the participant's name (its service).
    """

    is_sim = True

    def __init__(self, name: str) -> None:
        self.name = name
        self._now_ns = 0
        self._cond = threading.Condition()
        self._named_step = -1  # the latest step that named this participant
        self._named_time_ns = 0  # and its time
        self._acted_step = -1  # the step this participant last answered
        self._events = False
        self._ready_pub: Any = None
        self._stopping: threading.Event | None = None
        self._participating = False
        self._last_answer: dict[str, Any] | None = None
        self._stamp_ahead_ns = 0  # `answer_early`: this step's messages are stamped this much later
        self._answered = False  # `answer_early` already answered the current step
        self.steps = 0  # steps that named this participant

    def attach(self, node: ServiceNode) -> None:
        """Follow the owner's grants on `node`'s bus and answer on its own ready key."""
        self._stopping = node.stop_event
        self._ready_pub = node.publisher(topics.CLOCK_READY, own_stamps=True)
        node.session.declare_subscriber(grant_key(node.profile.prefix, self.name), self._on_sample)

    def _on_sample(self, sample: Any) -> None:  # Zenoh thread: decode and record, nothing else
        from bus_schema import decode
        try:
            grant = decode(topics.CLOCK, sample.payload.to_bytes())
        except Exception:  # noqa: BLE001 - a malformed grant is ignored; the owner sends the next
            return
        self.on_grant(grant.step, grant.time_ns, self.name in grant.due)

    def on_grant(self, step: int, time_ns: int, named: bool) -> None:
        """Step `step` at `time_ns` (ns) began; `named`: this participant must act at it. Its
        time moves when its `wait` takes the step, not here: a participant still at work on
        the last one (after `answer_early`) keeps that one's time and stamps."""
        with self._cond:
            if named and step > self._named_step:
                self._named_step, self._named_time_ns = step, time_ns
                self._cond.notify_all()

    def now_ns(self) -> int:
        """Simulated time, ns."""
        return self._now_ns

    def now_s(self) -> float:
        """Simulated time, s."""
        return self._now_ns / 1e9

    def stamp_ns(self) -> int:
        """The stamp of what this participant sends now, ns: the simulated time, or later after
        `answer_early`."""
        return self._now_ns + self._stamp_ahead_ns

    def answer_early(self, latency_s: float) -> None:
        """Answer the current step before its work is done, for a participant whose results
        take `latency_s` (s, > 0) of simulated time, as a sensor pipeline's do: it is done with
        now and next needs the clock at ``now + latency_s``, and what it sends until its next
        step is stamped ``now + latency_s``. The clock goes on meanwhile (other participants'
        steps run while it computes), and cannot pass ``now + latency_s`` before it has sent its
        results and answered again. Its inputs stay those stamped before now."""
        ahead_ns = max(1, seconds_to_ns(latency_s))
        self._participating = True
        self._send_ready(self._now_ns + ahead_ns)
        self._stamp_ahead_ns, self._answered = ahead_ns, True

    def note_event(self) -> None:
        """This participant sent an event in the current step (said in its next ready)."""
        self._events = True

    def wake(self) -> None:
        """Unblock `wait` (a shutdown request)."""
        with self._cond:
            self._cond.notify_all()

    def wait(self, timeout_s: float) -> bool:
        """Done with the current time; block until a step names this participant: at
        ``now + timeout_s`` or earlier (an event step), or until shutdown.

        Returns:
            True when a step came (False: shutdown).
        """
        if self._ready_pub is None:
            raise ClockError(f"{self.name}: the simulation clock is not attached to a bus session")
        # At least 1 ns on: a caller whose float sums fall a hair short of its deadline, or
        # that asks for 0, must see time move, or it would spin at one instant.
        next_ns = self._now_ns + max(1, seconds_to_ns(timeout_s))
        self._participating = True
        if self._answered:  # `answer_early` said when it next needs the clock
            self._answered = False
        else:
            self._send_ready(next_ns)
        repeat_at_s = time.monotonic() + (STOP_POLL_S if self._named_step < 0 else REPEAT_ANSWER_S)
        with self._cond:
            while self._named_step <= self._acted_step:
                if self._stopping is not None and self._stopping.is_set():
                    return False
                self._cond.wait(STOP_POLL_S)
                if self._last_answer is not None and time.monotonic() >= repeat_at_s \
                        and self._named_step <= self._acted_step:
                    self._ready_pub.put(**self._last_answer)  # see REPEAT_ANSWER_S
                    repeat_at_s = time.monotonic() + (STOP_POLL_S if self._named_step < 0 else REPEAT_ANSWER_S)
            self._acted_step = self._named_step
            self._now_ns = max(self._now_ns, self._named_time_ns)
        self._stamp_ahead_ns = 0
        self.steps += 1
        return True

    def _send_ready(self, next_ns: int, leaving: bool = False) -> None:
        events, self._events = self._events, False
        self._last_answer = dict(done_ns=self._now_ns, next_ns=max(next_ns, self._now_ns), events=events,
                                 leaving=leaving, pid=os.getpid())
        self._ready_pub.put(**self._last_answer)

    def close(self) -> None:
        """Leave the clock (the owner no longer waits for this participant)."""
        if self._ready_pub is not None and self._participating:
            try:
                self._send_ready(self._now_ns, leaving=True)
            except Exception:  # noqa: BLE001 - best effort: the session may be closing
                pass


def grant_key(prefix: str, participant: str) -> str:
    """The key the owner grants `participant`'s steps on: ``<prefix>/sim/clock/<participant>``
    (one key per participant: a step wakes only those it names)."""
    return f"{topics.CLOCK.key(prefix)}/{participant}"


def clock_source(profile_source: str | None) -> str:
    """The clock a process runs on: ``HANDOVER_CLOCK`` if set, else the profile's.

    Raises:
        ClockError: an unknown clock name.
    """
    source = os.environ.get(CLOCK_ENV) or profile_source or "wall"
    if source not in CLOCK_SOURCES:
        raise ClockError(f"unknown clock {source!r} (from {CLOCK_ENV} or the profile's [clock] source): "
                         f"use one of {', '.join(CLOCK_SOURCES)}")
    return source


#: The phase of every wall-clock loop grid of the stack, s: each loop of each process on a host
#: ticks at ``k · period`` of the host's monotonic clock, so the loops of all the processes wake
#: together instead of each at its own phase (the 100 Hz grid holds every point of the 20, 50
#: and 100 ms grids and every other point of the 25 ms one). On a virtual machine the first
#: wake of an idle CPU is what costs (docs/performance.md, "Timers on one grid"); wakes that
#: come together share it.
WALL_GRID_PHASE_S = 0.0


def seconds_to_wall_grid(period_s: float, now_s: float | None = None) -> float:
    """Seconds from `now_s` (monotonic s, default now) to the next point of the host's shared
    wall-clock grid of `period_s` (s, > 0; `WALL_GRID_PHASE_S`): a watch loop that waits this
    long wakes with the stack's other loops. Always more than a tenth of a period."""
    now_s = time.monotonic() if now_s is None else now_s
    return first_grid_time_s(now_s + period_s / 10, period_s, WALL_GRID_PHASE_S) - now_s


def grid_phase_s(name: str, owner: str = "bridge") -> float:
    """The phase of `name`'s loop grids on the simulation clock, s."""
    return 0.0 if name == owner else PARTICIPANT_PHASE_S


def first_grid_time_s(now_s: float, period_s: float, phase_s: float) -> float:
    """The first time of the grid ``phase_s + k · period_s`` at or after `now_s` (s)."""
    k = math.ceil((now_s - phase_s) / period_s - 1e-9)
    return phase_s + max(k, 0) * period_s
