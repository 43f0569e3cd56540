"""The simulation clock's barrier: which participant must act at the next step, and when time
may move on (pure logic; `services.runtime.clock_owner` wires it to the bus).

Times are simulated ns since the run's start. A participant registers with its first ready
(`ClockReady`); the clock starts once every expected participant has registered. A step is
granted at the earliest time any participant (or the owner) needs; those that need it are due
and the next step waits until each of them has answered. A step in which any participant sent
an event is followed by an event step `EVENT_STEP_NS` later at which every participant is due.
A participant that leaves, whose liveliness is lost or whose process is stopped or gone (the
owner asks the kernel) is excused: nobody waits for it until it answers again (a participant
blocked on the clock repeats its answer every `services.runtime.clock.REPEAT_ANSWER_S`, so one
that comes back, after a SIGCONT or a restart, is heard). Only the expected participants take
part: an answer in any other name is ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from services.runtime.clock import EVENT_STEP_NS

#: Time of a participant that needs no step (left or excused), ns.
NEVER_NS = (1 << 63) - 1


@dataclass
class Participant:
    """What the owner knows of one participant.

    Attributes:
        next_ns: the time it next needs, ns (`NEVER_NS`: none).
        pid: its process id (0 before its first ready).
        pending: it is due at the current step and has not answered yet.
        excused: the owner stopped waiting for it (left, lost, stopped or gone).
        registered: it has sent at least one ready.
    """

    next_ns: int = NEVER_NS
    pid: int = 0
    pending: bool = False
    excused: bool = False
    registered: bool = False


@dataclass(frozen=True)
class Step:
    """One granted step: its number, time (ns), the participants due at it and whether the
    owner is due too."""

    number: int
    time_ns: int
    due: tuple[str, ...]
    owner_due: bool


@dataclass
class ClockBarrier:
    """The owner's bookkeeping (not thread-safe: the owner holds its lock around every call).

    Args:
        expected: the participants the clock waits for before its first step.
    """

    expected: frozenset[str]
    participants: dict[str, Participant] = field(default_factory=dict)
    now_ns: int = 0
    steps: int = 0
    event_pending: bool = False
    excusals: int = 0
    event_steps: int = 0
    owner_only_steps: int = 0

    def __post_init__(self) -> None:
        for name in self.expected:
            self.participants[name] = Participant()

    # ------------------------------------------------------------------ inputs
    def ready(self, name: str, done_ns: int, next_ns: int, *, events: bool = False, leaving: bool = False,
              pid: int = 0) -> bool:
        """`name` is done up to `done_ns` and next needs `next_ns` (ns); `leaving`: it leaves.
        An answer from a name the clock does not expect is ignored (False); True otherwise."""
        p = self.participants.get(name)
        if p is None:
            return False
        p.registered = True
        if p.pending and done_ns < self.now_ns and not leaving:
            # An answer to an older step (a repeat, or an old process's): it still owes this
            # one, and an event it reports was already given its event step.
            return True
        if events:
            self.event_pending = True
        if leaving:
            p.next_ns, p.pending, p.excused = NEVER_NS, False, True
            return True
        p.pid = pid or p.pid
        p.excused = False  # back (SIGCONT, a restart, a late answer): it takes part again from now on
        p.pending = False
        p.next_ns = max(next_ns, self.now_ns)
        return True

    def excuse(self, name: str) -> None:
        """Stop waiting for `name` (lost, stopped or gone) until it answers again."""
        p = self.participants.get(name)
        if p is not None and not p.excused:
            p.excused, p.pending, p.next_ns = True, False, NEVER_NS
            self.excusals += 1

    # ------------------------------------------------------------------ state
    @property
    def started(self) -> bool:
        """Every expected participant has registered (or was excused)."""
        return all(p.registered or p.excused for name, p in self.participants.items() if name in self.expected)

    def unregistered(self) -> list[str]:
        """Expected participants not heard from yet."""
        return sorted(n for n in self.expected if not (self.participants[n].registered or self.participants[n].excused))

    def waiting_for(self) -> list[str]:
        """The participants the current step still waits for."""
        return sorted(n for n, p in self.participants.items() if p.pending)

    def pid_of(self, name: str) -> int:
        p = self.participants.get(name)
        return 0 if p is None else p.pid

    # ------------------------------------------------------------------ stepping
    def next_step(self, owner_next_ns: int) -> Step | None:
        """The next step, given that the owner next needs `owner_next_ns` (ns); None while the
        clock has not started or a due participant has not answered. The step's participants
        are marked pending; the owner is due when the step's time is `owner_next_ns` or at an
        event step."""
        if not self.started or self.waiting_for():
            return None
        active = {n: p for n, p in self.participants.items() if not p.excused and p.registered}
        if self.event_pending:
            self.event_pending = False
            time_ns = self.now_ns + EVENT_STEP_NS
            due = tuple(sorted(active))
            owner_due = True
            self.event_steps += 1
        else:
            time_ns = min([owner_next_ns, *(p.next_ns for p in active.values())])
            due = tuple(sorted(n for n, p in active.items() if p.next_ns <= time_ns))
            owner_due = owner_next_ns <= time_ns
        for name in due:
            active[name].pending = True
        if not due:
            self.owner_only_steps += 1
        self.now_ns = max(self.now_ns, time_ns)
        step = Step(self.steps, self.now_ns, due, owner_due)
        self.steps += 1
        return step
