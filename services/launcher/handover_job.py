"""The handover job of `handover-up`: follow the supervisor's episodes and report them.

The supervisor (a service of the profile) runs the episodes by itself; this job listens to
`supervisor/state` (prints every phase change), `supervisor/episode` (the summaries) and, in
simulation, `sim/truth` (where the object really is: never used for control, only to report
honestly whether it was dropped and who holds it at the end).

The job succeeds when every episode ended safely: released to the receiver, or a safe
``timeout``/``aborted`` (the robot kept the object), and the object was never dropped. A
``failed`` episode, a protective stop or a dropped object fails the job (exit 1) with the
reason on one line. The reading of the episodes is `services.launcher.episode_watch`; the
judgement of a silent supervisor, `services.launcher.supervisor_silence`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from bus_schema import topics
from bus_schema.messages import PHASES_OUTSIDE_EPISODE
from services.launcher.episode_watch import EpisodeReport, EpisodeWatch
from services.launcher.supervisor_silence import (
    NOTE_AFTER_S,
    SUPERVISOR_SILENT_S,
    SimClockSilence,
    SupervisorSilence,
)
from services.runtime import ServiceNode
from services.runtime.clock import WALL_GRID_PHASE_S, first_grid_time_s, seconds_to_wall_grid

#: Period of the job's look at the supervisor's freshness while it is quiet, s (on the host's
#: shared grid).
WATCH_PERIOD_S = 0.02
#: A loop iteration that began this much after the time it asked to wake means the launcher
#: itself was starved: states may still wait in its socket, s.
SELF_STALL_S = 0.08


def arrival_estimate_s(taken_s: float, previous_look_s: float, sent_s: float) -> float:
    """When a supervisor state taken in at `taken_s` arrived (all monotonic s): its send time
    (`sent_s`, its stamp on this host's monotonic clock) when that falls between the previous
    look (`previous_look_s`, which took every state there was) and `taken_s`, as for a state
    delivered at once; otherwise `taken_s`, the look that took it in, as the job always timed
    states (one that waited in delivery on a busy machine, or a stamp off this host's clock).

    The job looks up to 80 ms apart (`seconds_to_next_look`): timed by the look, a freeze
    right after a state would be seen up to that much late. Used on one host only."""
    return sent_s if previous_look_s < sent_s <= taken_s else taken_s


def seconds_to_next_look(silence: SupervisorSilence | SimClockSilence, now_s: float) -> float:
    """How long the job may sleep before it looks at the supervisor's freshness again, s.

    On the wall clock and one host, while the supervisor's states come, nothing can be judged
    before the newest is `NOTE_AFTER_S` old (timed by `arrival_estimate_s`): the job sleeps
    until then (the first point of the shared `WATCH_PERIOD_S` grid at or after it), instead
    of looking 50 times a second to find a fresh state each time (0.03 core of the launcher
    over an episode). From there on, as before the first episode, across hosts (a state is
    then timed by the look that takes it in) and on the simulation clock, it looks every
    `WATCH_PERIOD_S`: a silence is noted, judged and stopped on the same grid points as when
    it always looked. `now_s`: monotonic s."""
    if isinstance(silence, SupervisorSilence) and silence.one_host and silence.episode_begun \
            and silence.last_state_s is not None:
        look_s = first_grid_time_s(silence.last_state_s + NOTE_AFTER_S, WATCH_PERIOD_S, WALL_GRID_PHASE_S)
        if look_s - now_s > WATCH_PERIOD_S / 10:
            return look_s - now_s
    return seconds_to_wall_grid(WATCH_PERIOD_S, now_s)


@dataclass
class JobResult:
    ok: bool
    message: str = ""
    reports: list[EpisodeReport] = field(default_factory=list)


class _EpisodeFeed:
    """The job's bus side: its subscriptions and the arm's protective stop, feeding what it
    reads to the episode watch and the supervisor's silence. `follow_episodes` False (the
    ``none`` job's watch): phases are not said and summaries not read."""

    def __init__(self, node: ServiceNode, say: Callable[[str], None],
                 silence: SupervisorSilence | SimClockSilence, follow_episodes: bool = True) -> None:
        self.say = say
        self.silence = silence
        self.follow_episodes = follow_episodes
        self.watch = EpisodeWatch()
        # Read when the job looks (`seconds_to_next_look`); only a summary wakes it early.
        self.states = node.subscribe(topics.SUPERVISOR_STATE, queue_size=256, wake=False)
        #: When the job last took the states in (monotonic s): what it takes in now came since.
        self.looked_s = time.monotonic()
        self.summaries = node.subscribe(topics.EPISODE, queue_size=64) if follow_episodes else None
        # The episodes' reports, and on the simulation clock the stack's time (`SimClockSilence`).
        self.truth = (node.subscribe(topics.SIM_TRUTH, queue_size=1024, wake=False)
                      if follow_episodes or node.clock.is_sim else None)
        #: Whether the newest state is outside an episode (`PHASES_OUTSIDE_EPISODE`).
        self.resting = True
        # The node's one `motion/stop` publisher (`ServiceNode.publisher`): the launcher's
        # monitor sends through it too, so both stops share one numbering and are recorded.
        self.stop_pub = node.publisher(topics.MOTION_STOP)
        #: When the last progress line or summary came (monotonic s).
        self.last_progress_s = time.monotonic()

    def stopped(self, message: str, send: bool = True) -> JobResult:
        """Protective stop of the arm by the launcher itself (the supervisor may be gone);
        `send` False: the job's result only."""
        if send:
            try:
                self.stop_pub.put(reason=f"protective stop: {message}"[:512], protective=True)
            except Exception:  # noqa: BLE001 - the session is closing: the bridge holds on its command time-out
                pass
        return JobResult(False, message, self.watch.reports)

    def take_truth(self) -> None:
        if self.truth is None:
            return
        for rx in self.truth.drain():
            self.silence.saw_stack_time(rx.msg.stamp_ns / 1e9)
            self.watch.truth(rx.msg)

    def take_states(self) -> None:
        looked_s, self.looked_s = self.looked_s, time.monotonic()
        wall_minus_monotonic_s = time.time() - self.looked_s
        for rx in self.states.drain():
            stamp_s = rx.msg.stamp_ns / 1e9
            heard_s = rx.rx_monotonic  # the look that took it in (a ring channel's)
            if isinstance(self.silence, SupervisorSilence) and self.silence.one_host:
                heard_s = arrival_estimate_s(heard_s, looked_s, stamp_s - wall_minus_monotonic_s)
            self.silence.heard(heard_s, rx.msg.episode_id, stamp_s)
            self.resting = rx.msg.phase in PHASES_OUTSIDE_EPISODE
            line = self.watch.state(rx.msg)
            if line is not None and self.follow_episodes:
                self.say(line)
                self.last_progress_s = time.monotonic()

    def take_summaries(self, episodes: int) -> JobResult | None:
        """Report the new summaries; the job's result once one failed or `episodes` are done."""
        if self.summaries is None:
            return None
        for rx in self.summaries.drain():
            if not self.watch.accepts(rx.msg):
                self.say(f"WARNING: ignored an episode summary from {rx.msg.source!r} for episode "
                         f"{rx.msg.episode_id} (only the supervisor's first summary of an episode counts)")
                continue
            report = self.watch.summary(rx.msg)
            for line in report.lines:
                self.say(line)
            self.last_progress_s = time.monotonic()
            if not report.ok:
                summary = report.summary
                why = "the object was dropped" if report.dropped else f"{summary.outcome}: {summary.reason}"
                return JobResult(False, f"episode {report.summary.episode_id}: {why}", self.watch.reports)
            if episodes and len(self.watch.reports) >= episodes:
                return JobResult(True, "", self.watch.reports)
        return None


def run_handover_job(node: ServiceNode, episodes: int, abort_reason: Callable[[], str | None],
                     say: Callable[[str], None], episode_timeout_s: float = 90.0,
                     supervisor_pid: Callable[[], int | None] | None = None,
                     delivery_pids: tuple[int, ...] = (), follow_episodes: bool = True) -> JobResult:
    """Follow `episodes` episodes (0: until aborted); print progress with `say`.

    `follow_episodes` False: only the watch of the supervisor's silence (and the stop on an
    abort during an episode), until aborted: the ``none`` job's, so that a frozen supervisor
    stops the arm with no job too. Phases are not said, summaries not judged, `episodes` and
    `episode_timeout_s` unused.

    `supervisor_pid` (one host): the supervisor's process id, so that a supervisor starved of
    CPU (its threads waiting on the run queue) is not called silent before
    `services.runtime.sched.MAX_EXCUSED_S`; a stopped or hung one still is at
    `SUPERVISOR_SILENT_S`; nor while the processes its states pass through (`delivery_pids`:
    the router, this one) are starved. On the simulation clock the silence is counted in the
    stack's time (`SimClockSilence`)."""
    silence: SupervisorSilence | SimClockSilence = (
        SimClockSilence() if node.clock.is_sim else SupervisorSilence(supervisor_pid, delivery_pids))
    feed = _EpisodeFeed(node, say, silence, follow_episodes)
    if not follow_episodes:
        episodes, episode_timeout_s = 0, math.inf
    wait_s = seconds_to_wall_grid(WATCH_PERIOD_S)
    while True:
        wake_s = time.monotonic() + wait_s
        node.wait(wait_s)
        now_s = time.monotonic()
        late = now_s - wake_s > SELF_STALL_S
        silence.tick(now_s)
        feed.take_truth()
        feed.take_states()
        ended = feed.take_summaries(episodes)
        if ended is not None:
            return ended
        reason = abort_reason()
        if reason is not None:
            # The ``none`` watch stops the arm on an abort (Ctrl-C, a failed child) only in an
            # episode: an idle stack's Ctrl-C brakes nothing.
            return feed.stopped(reason, send=follow_episodes or not feed.resting)
        silent_s = silence.silent_s()
        if silent_s > SUPERVISOR_SILENT_S and late:
            # This loop was itself starved: let the states that waited in the socket in first.
            time.sleep(0.01)
            feed.take_states()
            silent_s = silence.silent_s()
        verdict = silence.judge(silent_s)
        if verdict.line is not None:
            say(verdict.line)
        if verdict.stop_reason is not None:
            return feed.stopped(verdict.stop_reason)
        if not math.isinf(episode_timeout_s) and time.monotonic() - feed.last_progress_s > episode_timeout_s:
            return JobResult(False, f"no progress from the supervisor for {episode_timeout_s:.0f} s",
                             feed.watch.reports)
        wait_s = seconds_to_next_look(silence, time.monotonic())
