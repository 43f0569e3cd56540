"""Whether the supervisor has fallen silent, for the launcher's handover job (no bus I/O).

The supervisor publishes its state at ≥ 20 Hz; nothing else watches the watcher, so the
launcher's job stops the arm itself when that stream goes quiet. The watch starts with the
first episode: before it nothing can move the arm (a supervisor that dies then is seen by its
liveliness, one that hangs by the episode time-out), and the start-up burst, in which a starved
router delays every state, is over (docs/performance.md, busy machine).

On one host (the supervisor's process id known) a silence is judged by the processes' run-queue
wait (`services.runtime.sched.StarvationJudge`): a supervisor starved of CPU, or whose states
wait in a starved router or in this process, is excused up to
`services.runtime.sched.MAX_EXCUSED_S`; a stopped (SIGSTOP) or hung one is not.

On the simulation clock (`SimClockSilence`) the silence is counted in the stack's time: a
supervisor is a participant of the clock, so a busy machine slows its time and cannot make it
silent; only a supervisor the clock went on without (stopped or gone) falls behind.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import NamedTuple

from services.runtime.sched import MAX_EXCUSED_S, StarvationJudge

#: Older than this, the supervisor's state means it is frozen or hung: the job stops the arm
#: itself and fails, s.
SUPERVISOR_SILENT_S = 0.2
#: A supervisor quiet this long is read from /proc at each loop (to judge starvation), s.
NOTE_AFTER_S = 0.08
#: A supervisor this quiet whose process is stopped (SIGSTOP) is silent at once, s.
STOPPED_AFTER_S = 0.1
#: An excused silence is reported at most this often, s.
EXCUSE_LINE_EVERY_S = 5.0


class SilenceVerdict(NamedTuple):
    """What the job does about the supervisor's silence: stop the arm with `stop_reason` (one
    line), or go on, saying `line` (an excused silence) when it is not None."""

    stop_reason: str | None = None
    line: str | None = None


class SupervisorSilence:
    """Keeps when the supervisor was last heard from and judges its silence.

    Args:
        supervisor_pid: (one host) the supervisor's process id, read when a silence is judged;
            None (other hosts): no silence is excused.
        delivery_pids: the processes its states pass through (the router, this one).
        judge: the starvation judge (tests pass a fake); by default a
            `services.runtime.sched.StarvationJudge` when `supervisor_pid` is given.
        clock: monotonic clock, s.
    """

    def __init__(self, supervisor_pid: Callable[[], int | None] | None = None, delivery_pids: tuple[int, ...] = (),
                 judge: StarvationJudge | None = None, clock: Callable[[], float] = time.monotonic) -> None:
        self._supervisor_pid = supervisor_pid
        self._delivery_pids = delivery_pids
        self._judge = None if supervisor_pid is None else (judge if judge is not None else StarvationJudge())
        self._clock = clock
        #: Receive time of the supervisor's latest state (monotonic s), None before the first.
        self.last_state_s: float | None = None
        #: Whether a state of episode 1 or later has been seen (the watch starts there).
        self.episode_begun = False
        self._excused_said_s = -math.inf

    @property
    def one_host(self) -> bool:
        """Whether the supervisor runs on this host (its process id is asked for): its stamps
        are then on this host's clock."""
        return self._supervisor_pid is not None

    def tick(self, now_s: float) -> None:
        """At every loop of the job, monotonic `now_s` s: keeps the machine's CPU figures."""
        if self._judge is not None:
            self._judge.tick(now_s)

    def saw_stack_time(self, stamp_s: float) -> None:
        """A message stamped `stamp_s` (s) was received: nothing to do on the wall clock."""

    def heard(self, rx_monotonic_s: float, episode_id: int, stamp_s: float = 0.0) -> None:
        """A supervisor state of `episode_id` received at `rx_monotonic_s` (monotonic s),
        stamped `stamp_s` (s; unused on the wall clock)."""
        self.last_state_s = rx_monotonic_s
        self.episode_begun = self.episode_begun or episode_id >= 1

    def silent_s(self) -> float:
        """How long the supervisor has been silent, s (0 before the first episode)."""
        if self.last_state_s is None or not self.episode_begun:
            return 0.0
        return self._clock() - self.last_state_s

    def judge(self, silent_s: float) -> SilenceVerdict:
        """Judge a silence of `silent_s` s (from `silent_s()`): a stop when it is longer than
        `SUPERVISOR_SILENT_S` and not excused, or when the supervisor's process is stopped
        after `STOPPED_AFTER_S`."""
        judge = self._judge
        pid = None
        if judge is not None and self._supervisor_pid is not None and silent_s > NOTE_AFTER_S:
            pid = self._supervisor_pid()
        if judge is not None and pid is not None:
            for watched in (pid, *self._delivery_pids):
                judge.note(watched, self._clock(), self.last_state_s)
            if silent_s > STOPPED_AFTER_S and judge.is_stopped_now(pid, self._clock()):
                return SilenceVerdict(f"supervisor: silent: no supervisor/state for {silent_s:.3f} s, its process "
                                      "is stopped; the launcher stopped the arm")
        if silent_s <= SUPERVISOR_SILENT_S:
            return SilenceVerdict()
        why = self._excuse(pid, silent_s)
        if why is None:
            return SilenceVerdict(f"supervisor: silent: no supervisor/state for {silent_s:.3f} s; "
                                  "the launcher stopped the arm")
        if self._clock() - self._excused_said_s <= EXCUSE_LINE_EVERY_S:
            return SilenceVerdict()
        self._excused_said_s = self._clock()
        return SilenceVerdict(line=f"supervisor: no supervisor/state for {silent_s:.3f} s, "
                                   f"excused: starved of CPU ({why})")

    def _excuse(self, pid: int | None, silent_s: float) -> str | None:
        """Why a silence of `silent_s` s of the supervisor (process `pid`) is starvation, its own
        or its delivery path's (one clause), or None when it is not excused."""
        judge = self._judge
        if judge is None or pid is None or silent_s > MAX_EXCUSED_S or judge.stopped(pid, self._clock()):
            return None
        return judge.excuse(pid, self._clock()) or judge.excuse_path(self._delivery_pids, self._clock())


#: On the simulation clock, a state's delivery may trail later messages of other senders by a
#: few milliseconds (Zenoh orders samples per sender only); a silence is judged only once no
#: state has come for this long on the wall clock too, s.
SIM_WALL_GRACE_S = 0.05


class SimClockSilence:
    """The supervisor's silence on the simulation clock, in the stack's time: the latest stamp
    seen on the bus (``sim/truth``, at least 10 Hz while the scene simulates) minus the stamp of
    the supervisor's latest state. Nothing is excused: starvation slows the stack's time instead
    of silencing the supervisor, whose steps the clock waits for; the owner goes on without it
    only once it is stopped or gone (`services.runtime.clock_owner`).

    Args:
        clock: monotonic wall clock, s (for `SIM_WALL_GRACE_S`).
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        #: The latest stamp seen on the bus, s of stack time (None before the first).
        self.stack_now_s: float | None = None
        #: Stamp (stack s) and receive time (monotonic s) of the supervisor's latest state.
        self.last_state_stamp_s: float | None = None
        self.last_state_s: float | None = None
        self.episode_begun = False

    def tick(self, now_s: float) -> None:
        """Nothing to keep (no starvation figures on the simulation clock)."""

    def saw_stack_time(self, stamp_s: float) -> None:
        """A message stamped `stamp_s` (stack s) was received."""
        if self.stack_now_s is None or stamp_s > self.stack_now_s:
            self.stack_now_s = stamp_s

    def heard(self, rx_monotonic_s: float, episode_id: int, stamp_s: float = 0.0) -> None:
        """A supervisor state of `episode_id` stamped `stamp_s` (stack s), received at
        `rx_monotonic_s` (monotonic s)."""
        self.saw_stack_time(stamp_s)
        self.last_state_stamp_s, self.last_state_s = stamp_s, rx_monotonic_s
        self.episode_begun = self.episode_begun or episode_id >= 1

    def silent_s(self) -> float:
        """How long the supervisor has been silent, s of stack time (0 before the first
        episode, and while a state came within `SIM_WALL_GRACE_S` of wall time)."""
        if self.last_state_s is None or self.last_state_stamp_s is None or self.stack_now_s is None \
                or not self.episode_begun or self._clock() - self.last_state_s <= SIM_WALL_GRACE_S:
            return 0.0
        return self.stack_now_s - self.last_state_stamp_s

    def judge(self, silent_s: float) -> SilenceVerdict:
        """A stop once the silence is longer than `SUPERVISOR_SILENT_S` of stack time."""
        if silent_s <= SUPERVISOR_SILENT_S:
            return SilenceVerdict()
        return SilenceVerdict(f"supervisor: silent: no supervisor/state for {silent_s:.3f} s of simulated time; "
                              "the launcher stopped the arm")
