"""Was a silent process starved of CPU, or is it frozen? (one host; `/proc` reads only.)

A watchdog that hears nothing from a service for its time-out cannot tell, from the silence
alone, a process the kernel never let run (a busy machine: a compile, a test run, the viewer)
from a frozen or hung one. The kernel can: per thread it counts the time spent waiting on the
run queue, runnable but not running (``/proc/PID/task/TID/schedstat``, second field, ns), and
it says whether a process is stopped (``/proc/PID/stat`` state ``T``/``t``).

`StarvationJudge.excuse(pid, now_s)` answers for one watched process:

- **stopped** (never excused, seen at once): state ``T`` — a SIGSTOP, the freeze of the fault
  matrix — or gone.
- **starved** (excused): over the whole quiet spell (from the first reading, taken once the
  process has been quiet for a beat) or over the last window (≥ `WINDOW_S`), either
  - its threads together waited on the run queue for at least `STARVED_FRACTION` of the time, or
  - the machine was short of CPU since the process went quiet (`services.runtime.machine_load`:
    some task waited for a CPU at least half of the time, or the host took 30 % of it), judged
    from a reading taken before the silence began (the watcher's `tick`), so that a watcher
    starved through the silence itself still judges it right.
- otherwise not excused: a blocked, deadlocked or spinning process on a machine with CPU to
  spare.

Why the machine's pressure counts. The kernel adds a thread's run-queue wait to ``schedstat``
only when the thread gets a CPU: a process that is waiting *now* shows none of that wait. Beside
two busy loops, the watcher read "0 ms waited in the last 90 ms (state R)" for a service whose
own report, once it ran, said its main thread had waited 175 ms for a CPU (a heartbeat is
written by a Python thread, which may wait on the GIL behind a thread that waits for a CPU, and
sent by Zenoh's worker thread). Half of the faults run beside two hogs ended in such false stops.
The pressure is machine-wide and up to date at every read. The price: on a machine short of CPU,
a hung (not stopped) process is caught at `MAX_EXCUSED_S` rather than at its time-out; a
stopped or killed one is caught as fast as ever.

Why the whole spell: a service that missed its beat because it waited for a CPU may be running
again by the time the watcher judges (its late beat on the way); the last window alone then
shows a running process.

A message also crosses the router and the watcher's own receive threads: when either of them is
starved, every service looks silent at once although none is. `excuse_path(pids, now_s)` judges
those processes the same way (the watcher notes them whenever anyone is quiet).

The caller bounds the excuse (`MAX_EXCUSED_S`: a silence longer than that is a fault whatever
the reason) and uses it only when every watched process runs on this host.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from services.runtime.exits import ExitWatch
from services.runtime.machine_load import MachineHistory
from services.runtime.starvation import parse_schedstat

#: Environment variable through which the launcher gives its children the router's pid.
ROUTER_PID_ENV = "HANDOVER_ROUTER_PID"
#: Shortest window over which run-queue wait is judged, s.
WINDOW_S = 0.08
#: A reading older than this starts a new window instead of closing one (an earlier quiet
#: spell's), s.
STALE_BASE_S = 4 * WINDOW_S
#: A process whose threads waited on the run queue for at least this fraction of the
#: time judged was starved of CPU, not frozen (a frozen or blocked one waits 0; one runnable
#: thread among four on two CPUs waits about half the time, among three about a third).
STARVED_FRACTION = 0.3
#: A silence longer than this is a fault even when the process was starved, s.
MAX_EXCUSED_S = 1.0
_STOPPED_STATES = frozenset("TtZXx")


@dataclass(frozen=True)
class SchedSample:
    """One reading of a process's scheduler figures.

    Attributes:
        at_s: local monotonic time of the reading, s.
        queue_wait_s: run-queue wait of all its threads so far, s.
        state: the main thread's state letter (``R``, ``S``, ``D``, ``T`` …).
    """

    at_s: float
    queue_wait_s: float
    state: str


def parse_state(stat_text: str) -> str | None:
    """The state letter of a ``/proc/PID/stat`` line (the field after the ``(comm)``)."""
    close = stat_text.rfind(")")
    if close < 0 or close + 2 >= len(stat_text):
        return None
    return stat_text[close + 2]


def read_sched(pid: int, at_s: float, proc_root: str = "/proc") -> SchedSample | None:
    """`SchedSample` of process `pid` now (None when it is gone or unreadable)."""
    base = f"{proc_root}/{pid}"
    try:
        with open(f"{base}/stat", "rb") as f:
            state = parse_state(f.read(512).decode("ascii", "replace"))
        wait_s = 0.0
        for tid in os.listdir(f"{base}/task"):
            try:
                with open(f"{base}/task/{tid}/schedstat", "rb") as f:
                    wait = parse_schedstat(f.read(128).decode("ascii", "replace"))
            except OSError:  # the thread ended meanwhile
                continue
            wait_s += wait or 0.0
    except OSError:
        return None
    if state is None:
        return None
    return SchedSample(at_s, wait_s, state)


def read_state(pid: int, proc_root: str = "/proc") -> str | None:
    """The state letter of process `pid` now (``/proc/PID/stat`` alone), None when it is gone."""
    try:
        with open(f"{proc_root}/{pid}/stat", "rb") as f:
            return parse_state(f.read(512).decode("ascii", "replace"))
    except OSError:
        return None


def starved(older: SchedSample, newer: SchedSample, fraction: float = STARVED_FRACTION) -> bool:
    """True when, between the two samples, the process waited on the run queue for at least
    `fraction` of the time and is not stopped now."""
    span = newer.at_s - older.at_s
    if span <= 0.0 or newer.state in _STOPPED_STATES:
        return False
    return newer.queue_wait_s - older.queue_wait_s >= fraction * span


class StarvationJudge:
    """Judges watched processes by their run-queue wait (see the module docstring).

    Call `note(pid, now_s)` at the watcher's tick for every watched process that has been
    quiet for a while (cheap: it reads only once per `WINDOW_S` per process), and
    `excuse(pid, now_s)` when one looks silent.

    Call `tick(now_s)` at every tick of the watcher: it keeps the machine's CPU pressure, so that
    a silence can be judged against the machine from before it began.

    Args:
        read: `read_sched`-like reader (tests pass a fake).
        machine: the machine's readings (tests pass one with a fake reader).
    """

    def __init__(self, read=read_sched, machine: MachineHistory | None = None) -> None:
        self._read = read
        # The state alone is one small file; a fake `read` (tests) gives it with its sample.
        self._state = read_state if read is read_sched else self._state_from_read
        self.machine = machine if machine is not None else MachineHistory()
        self._since: dict[int, float] = {}  # when each quiet process was last heard from
        self._machine_seen: dict[int, str] = {}  # what the machine did in its silence
        self._first: dict[int, SchedSample] = {}  # of the quiet spell
        self._base: dict[int, SchedSample] = {}  # of the window being measured
        self._verdict: dict[int, tuple[bool, str]] = {}

    def note(self, pid: int, now_s: float, quiet_since_s: float | None = None) -> None:
        """Take a reading of `pid` if the last is at least `WINDOW_S` old, and judge the
        window and the whole quiet spell.

        `quiet_since_s`: when the watched service was last heard from (monotonic s): readings
        older than that belong to an earlier spell and are dropped."""
        first = self._first.get(pid)
        if first is not None and quiet_since_s is not None and first.at_s < quiet_since_s:
            self.forget(pid)
        base = self._base.get(pid)
        if base is not None and now_s - base.at_s > STALE_BASE_S:  # from an earlier quiet spell
            self.forget(pid)
            base = None
        if quiet_since_s is not None:
            self._since[pid] = quiet_since_s
        if base is not None and now_s - base.at_s < WINDOW_S:
            return
        sample = self._read(pid, now_s)
        if sample is None:
            self.forget(pid)
            self._verdict[pid] = (False, "process not readable")
            return
        first = self._first.setdefault(pid, sample)
        if base is not None:
            self._verdict[pid] = self._judge(first, base, sample)
        self._base[pid] = sample

    @staticmethod
    def _judge(first: SchedSample, base: SchedSample, sample: SchedSample) -> tuple[bool, str]:
        """Verdict over the spell (first → sample) or, failing that, the last window."""
        for older, what in ((first, "since it went quiet"), (base, "in the last window")):
            if starved(older, sample):
                break
        waited_ms = 1000.0 * (sample.queue_wait_s - older.queue_wait_s)
        why = (f"its threads waited {waited_ms:.0f} ms for a CPU in {1000.0 * (sample.at_s - older.at_s):.0f} ms "
               f"{what} (state {sample.state})")
        return starved(older, sample), why

    def tick(self, now_s: float) -> None:
        """Keep the machine's figures (cheap: one reading per `SAMPLE_PERIOD_S` at most)."""
        self.machine.observe(now_s)

    def forget(self, pid: int) -> None:
        """Drop what is known of `pid` (a process heard from again, or gone)."""
        self._since.pop(pid, None)
        self._machine_seen.pop(pid, None)
        self._first.pop(pid, None)
        self._base.pop(pid, None)
        self._verdict.pop(pid, None)

    def _state_from_read(self, pid: int) -> str | None:
        sample = self._read(pid, 0.0)
        return None if sample is None else sample.state

    def stopped(self, pid: int, now_s: float) -> bool:
        """True when `pid` is stopped (SIGSTOP), a zombie, gone or unreadable now."""
        state = self._state(pid)
        return state is None or state in _STOPPED_STATES

    def is_stopped_now(self, pid: int, now_s: float) -> bool:
        """True only when `pid` is readable and stopped (``T``/``t``): a process that surely
        cannot run until it is continued (gone or unreadable: False, liveliness tells)."""
        state = self._state(pid)
        return state is not None and state in "Tt"

    def excuse(self, pid: int, now_s: float, machine: bool = True) -> str | None:
        """Why `pid`'s silence is starvation (one clause), or None when it is not excused.

        `machine=False`: judge by the process's own run-queue wait only (the delivery path's
        processes: the machine's verdict is the silent service's to use, never theirs, or a
        stopped service would be excused by a busy router)."""
        self.note(pid, now_s)
        if self.stopped(pid, now_s):  # stopped since the last window? (SIGSTOP is never excused)
            return None
        verdict = self._verdict.get(pid)
        if verdict is not None and verdict[0]:
            return verdict[1]
        if not machine:
            return None
        since_s = self._since.get(pid)
        judged = None if since_s is None else self.machine.judge(since_s, now_s)
        if judged is None:
            self._machine_seen.pop(pid, None)
            return None
        self._machine_seen[pid] = judged[1]
        return judged[1] if judged[0] else None

    def explain(self, pid: int) -> str:
        """The last judgement of `pid`, for the line that reports a silence not excused."""
        verdict = self._verdict.get(pid)
        own = ("no window judged yet" if verdict is None
               else ("starved: " if verdict[0] else "not starved: ") + verdict[1])
        seen = self._machine_seen.get(pid)
        return own if seen is None else f"{own}; {seen}"

    def excuse_path(self, pids: tuple[int, ...], now_s: float) -> str | None:
        """Why the delivery path (the router, the watcher itself) was starved, or None."""
        for pid in pids:
            why = self.excuse(pid, now_s, machine=False)
            if why is not None:
                return f"the delivery path was starved: pid {pid}: {why}"
        return None


def delivery_pids() -> tuple[int, ...]:
    """This process and the stack's router (from `ROUTER_PID_ENV`, set by the launcher): the
    processes a message to this watcher passes through on one host."""
    pids = [os.getpid()]
    router = os.environ.get(ROUTER_PID_ENV, "")
    if router.isdigit() and int(router) > 0:
        pids.append(int(router))
    return tuple(pids)


def runs_a_service(pid: int, proc_root: str = "/proc") -> bool:
    """True when process `pid` on this host runs one of the stack's modules
    (``python -m services.…``): a process id read from the bus is used only then."""
    try:
        with open(f"{proc_root}/{pid}/cmdline", "rb") as f:
            argv = f.read(4096).split(b"\0")
    except OSError:
        return False
    return any(arg.startswith(b"services.") for arg in argv)


class ServiceStarvation:
    """`StarvationJudge` by service name, for `services.supervisor.watchdog.Watchdog` (an
    `Excuser`): each service's process id comes with its heartbeats (`Heartbeat.pid`) and is
    used once `/proc/PID/cmdline` shows a module of the stack."""

    def __init__(self, judge: StarvationJudge | None = None, check_pid=runs_a_service,
                 path_pids: tuple[int, ...] = ()) -> None:
        self.judge = judge or StarvationJudge()
        self._check_pid = check_pid
        self.path_pids = path_pids
        self.exits = ExitWatch()
        self._pids: dict[str, int] = {}
        self._refused: set[int] = set()

    def heard(self, service: str, pid: int) -> None:
        """A heartbeat of `service` said it runs as `pid` (0: not said)."""
        if pid <= 0 or self._pids.get(service) == pid or pid in self._refused:
            return
        if not self._check_pid(pid):
            self._refused.add(pid)
            return
        old = self._pids.get(service)
        if old is not None:
            self.judge.forget(old)
        self._pids[service] = pid
        self.exits.watch(service, pid)

    def exited(self) -> set[str]:
        """The services whose process has ended, as the kernel says (`ExitWatch`)."""
        return self.exits.exited()

    def stopped(self, service: str, now_s: float) -> bool:
        """True when `service`'s process is known and stopped now (SIGSTOP: state ``T``)."""
        pid = self._pids.get(service)
        return pid is not None and self.judge.is_stopped_now(pid, now_s)

    def revived(self, service: str) -> None:
        """`service` is alive again (a restart): its old process no longer speaks for it."""
        self.exits.forget(service)
        pid = self._pids.pop(service, None)
        if pid is not None:
            self.judge.forget(pid)

    def note(self, service: str, now_s: float, quiet_since_s: float | None = None) -> None:
        pid = self._pids.get(service)
        if pid is not None:
            self.judge.note(pid, now_s, quiet_since_s)
        for path_pid in self.path_pids:
            self.judge.note(path_pid, now_s, quiet_since_s)

    def tick(self, now_s: float) -> None:
        self.judge.tick(now_s)

    def excuse(self, service: str, now_s: float) -> str | None:
        """Why `service`'s silence is starvation, or None. A stopped or gone service is never
        excused, whatever its delivery path went through."""
        pid = self._pids.get(service)
        if pid is not None and self.judge.stopped(pid, now_s):
            return None
        why = None if pid is None else self.judge.excuse(pid, now_s)
        return why or self.judge.excuse_path(self.path_pids, now_s)

    def explain(self, service: str) -> str:
        """Why a silence of `service` was not excused: the last judgement of its process and of
        the delivery path (one line, for the fault's log line)."""
        pid = self._pids.get(service)
        own = "pid unknown" if pid is None else f"pid {pid} {self.judge.explain(pid)}"
        path = "; ".join(f"path pid {p} {self.judge.explain(p)}" for p in self.path_pids)
        return f"{own}; {path}" if path else own
