"""The handover job of `handover-up`: follow the supervisor's episodes and report them.

The supervisor (a service of the profile) runs the episodes by itself; this job listens to
`supervisor/state` (prints every phase change), `supervisor/episode` (the summaries) and, in
simulation, `sim/truth` (where the object really is: never used for control, only to report
honestly whether it was dropped and who holds it at the end).

The job succeeds when every episode ended safely: released to the receiver, or a safe
``timeout``/``aborted`` (the robot kept the object), and the object was never dropped. A
``failed`` episode, a protective stop or a dropped object fails the job (exit 1) with the
reason on one line.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from bus_schema import topics
from bus_schema.messages import EpisodeSummary, SimTruth, SupervisorState
from services.runtime import ServiceNode
from services.runtime.sched import MAX_EXCUSED_S, StarvationJudge

SAFE_OUTCOMES = ("released", "timeout", "aborted")
#: The one service whose episode summaries the job takes.
SUPERVISOR = "supervisor"
#: The supervisor publishes its state at ≥ 20 Hz; older than this, it is frozen or hung
#: (nothing else watches the watcher): the job stops the arm itself and fails, s.
SUPERVISOR_SILENT_S = 0.2
#: The job's loop wakes at least this often to judge the supervisor's freshness, s.
WATCH_PERIOD_S = 0.02
#: A loop iteration this much after the previous one (it waits at most 20 ms) means the
#: launcher itself was starved: states may still wait in its socket.
SELF_STALL_S = 0.1
#: A supervisor quiet this long is read from /proc at each loop (to judge starvation), s.
NOTE_AFTER_S = 0.08
#: A supervisor this quiet whose process is stopped (SIGSTOP) is silent at once, s.
STOPPED_AFTER_S = 0.1


@dataclass
class EpisodeReport:
    """One finished episode as the job saw it."""

    summary: EpisodeSummary
    dropped: bool
    final_holder: str | None
    lines: list[str]

    @property
    def ok(self) -> bool:
        """Safe, never dropped, and (in simulation) released only into the receiver's hand."""
        released_elsewhere = (self.summary.outcome == "released" and self.final_holder is not None
                              and self.final_holder != "receiver")
        return self.summary.outcome in SAFE_OUTCOMES and not self.dropped and not released_elsewhere


@dataclass
class EpisodeWatch:
    """Turns bus messages into progress lines and episode reports (no I/O)."""

    reports: list[EpisodeReport] = field(default_factory=list)
    _phase: tuple[int, str, str] | None = None
    _dropped: dict[int, bool] = field(default_factory=dict)
    _holder: str | None = None
    _episode: int = 0

    def state(self, msg: SupervisorState) -> str | None:
        """A line when the phase (or its reason) changed, else None."""
        key = (msg.episode_id, msg.phase, msg.reason)
        if key == self._phase:
            return None
        self._phase = key
        self._episode = msg.episode_id
        return f"episode {msg.episode_id}: {msg.phase}" + (f" ({msg.reason})" if msg.reason else "")

    def truth(self, msg: SimTruth) -> None:
        self._holder = msg.held_by
        if msg.dropped:
            self._dropped[self._episode] = True

    def accepts(self, msg: EpisodeSummary) -> bool:
        """Only the supervisor's summary counts, and only its first of each episode: a copy,
        or a summary from anyone else, cannot end the run or change its verdict."""
        return msg.source == SUPERVISOR and all(r.summary.episode_id != msg.episode_id for r in self.reports)

    def summary(self, msg: EpisodeSummary) -> EpisodeReport:
        dropped = self._dropped.get(msg.episode_id, False)
        lines = [f"episode {msg.episode_id}: {msg.outcome.upper()}: {msg.reason}"]
        if msg.transfer_point_base_m is not None:
            x, y, z = msg.transfer_point_base_m
            lines.append(f"  transfer point (base frame): x {x:+.3f}  y {y:+.3f}  z {z:+.3f} m "
                         f"({msg.receiver_posture} receiver)")
        if self._holder is not None:
            where = {"receiver": "in the receiver's hand", "gripper": "in the gripper", "both": "held by both",
                     "table": "on the table", "none": "held by nobody"}.get(self._holder, self._holder)
            fate = "DROPPED during the episode" if dropped else "never dropped"
            lines.append(f"  object (sim truth): {where}; {fate}")
        rest = f"; release → arm at rest {msg.release_to_stop_s * 1000:.0f} ms" if msg.outcome == "released" else ""
        lines.append(f"  grip: peak {msg.peak_grip_force_n:.1f} N, overshoot {msg.force_overshoot_n:.1f} N{rest}")
        if msg.phase_durations_s:
            lines.append("  phases: " + ", ".join(f"{k} {v:.2f} s" for k, v in msg.phase_durations_s.items()))
        if msg.replans:
            lines.append(f"  re-plans: {msg.replans}")
        if msg.faults:
            lines.append("  faults: " + "; ".join(msg.faults))
        report = EpisodeReport(msg, dropped, self._holder, lines)
        self.reports.append(report)
        return report


@dataclass
class JobResult:
    ok: bool
    message: str = ""
    reports: list[EpisodeReport] = field(default_factory=list)


def run_handover_job(node: ServiceNode, episodes: int, abort_reason: Callable[[], str | None],
                     say: Callable[[str], None], episode_timeout_s: float = 90.0,
                     supervisor_pid: Callable[[], int | None] | None = None,
                     delivery_pids: tuple[int, ...] = ()) -> JobResult:
    """Follow `episodes` episodes (0: until aborted); print progress with `say`.

    `supervisor_pid` (one host): the supervisor's process id, so that a supervisor starved of
    CPU (its threads waiting on the run queue) is not called silent before
    `services.runtime.sched.MAX_EXCUSED_S`; a stopped or hung one still is at
    `SUPERVISOR_SILENT_S`; nor while the processes its states pass through (`delivery_pids`:
    the router, this one) are starved."""
    judge = StarvationJudge() if supervisor_pid is not None else None
    excused_log_s = -math.inf
    watch = EpisodeWatch()
    # Read at this loop's 50 Hz tick; only a summary wakes it early.
    states = node.subscribe(topics.SUPERVISOR_STATE, queue_size=256, wake=False)
    summaries = node.subscribe(topics.EPISODE, queue_size=64)
    truth = node.subscribe(topics.SIM_TRUTH, queue_size=1024, wake=False)
    stop_pub = node.publisher(topics.MOTION_STOP)
    last_progress = time.monotonic()
    last_state_s: float | None = None
    # Before the supervisor's first episode nothing can move the arm: a supervisor that dies
    # then is seen by its liveliness (`abort_reason`), one that hangs by the episode time-out.
    # The freshness watch starts with the first episode, after the start-up burst in which a
    # starved router delays every state (docs/performance.md, busy machine).
    episode_begun = False

    def stopped(message: str) -> JobResult:
        """Protective stop of the arm by the launcher itself (the supervisor may be gone)."""
        try:
            stop_pub.put(reason=f"protective stop: {message}"[:512], protective=True)
        except Exception:  # noqa: BLE001 - the session is closing: the bridge holds on its command time-out
            pass
        return JobResult(False, message, watch.reports)

    def take_states() -> None:
        nonlocal last_state_s, last_progress, episode_begun
        for rx in states.drain():
            last_state_s = rx.rx_monotonic
            episode_begun = episode_begun or rx.msg.episode_id >= 1
            line = watch.state(rx.msg)
            if line is not None:
                say(line)
                last_progress = time.monotonic()

    last_loop_s = time.monotonic()
    while True:
        node.wait(WATCH_PERIOD_S)
        now_s = time.monotonic()
        late, last_loop_s = now_s - last_loop_s > SELF_STALL_S, now_s
        if judge is not None:
            judge.tick(now_s)
        for rx in truth.drain():
            watch.truth(rx.msg)
        take_states()
        for rx in summaries.drain():
            if not watch.accepts(rx.msg):
                say(f"WARNING: ignored an episode summary from {rx.msg.source!r} for episode {rx.msg.episode_id} "
                    "(only the supervisor's first summary of an episode counts)")
                continue
            report = watch.summary(rx.msg)
            for line in report.lines:
                say(line)
            last_progress = time.monotonic()
            if not report.ok:
                summary = report.summary
                why = "the object was dropped" if report.dropped else f"{summary.outcome}: {summary.reason}"
                return JobResult(False, f"episode {report.summary.episode_id}: {why}", watch.reports)
            if episodes and len(watch.reports) >= episodes:
                return JobResult(True, "", watch.reports)
        reason = abort_reason()
        if reason is not None:
            return stopped(reason)
        silent_s = time.monotonic() - last_state_s if last_state_s is not None and episode_begun else 0.0
        if silent_s > SUPERVISOR_SILENT_S and late:
            # This loop was itself starved: let the states that waited in the socket in first.
            time.sleep(0.01)
            take_states()
            silent_s = time.monotonic() - last_state_s if last_state_s is not None and episode_begun else 0.0
        pid = supervisor_pid() if judge is not None and silent_s > NOTE_AFTER_S else None
        if pid is not None:
            for watched in (pid, *delivery_pids):
                judge.note(watched, time.monotonic(), last_state_s)
        if pid is not None and silent_s > STOPPED_AFTER_S and judge.is_stopped_now(pid, time.monotonic()):
            return stopped(f"supervisor: silent: no supervisor/state for {silent_s:.3f} s, its process is stopped; "
                           "the launcher stopped the arm")
        if silent_s > SUPERVISOR_SILENT_S:
            why = None
            if pid is not None and silent_s <= MAX_EXCUSED_S and not judge.stopped(pid, time.monotonic()):
                why = judge.excuse(pid, time.monotonic()) or judge.excuse_path(delivery_pids, time.monotonic())
            if why is None:
                return stopped(f"supervisor: silent: no supervisor/state for {silent_s:.3f} s; "
                               "the launcher stopped the arm")
            if time.monotonic() - excused_log_s > 5.0:
                excused_log_s = time.monotonic()
                say(f"supervisor: no supervisor/state for {silent_s:.3f} s, excused: starved of CPU ({why})")
        if not math.isinf(episode_timeout_s) and time.monotonic() - last_progress > episode_timeout_s:
            return JobResult(False, f"no progress from the supervisor for {episode_timeout_s:.0f} s", watch.reports)
