"""Bus wiring of the supervisor: everything in, motion goals / stops / state / summaries out.

The loop sleeps on the bus between 100 Hz ticks (`node.wait`; 40 Hz once the last episode
has ended, `supervision.RESTING_PERIOD_S`), so a release event is acted on as soon as it
arrives (the stop goes out before anything else is looked at), not at the next tick.
Liveliness changes arrive on a Zenoh thread and are queued; heartbeats and the watched data
streams are drained every wake-up. All decisions are in `supervision.Supervision` (the
sequencer `core.Sequencer` and the watch `health.HealthWatch`).
"""

from __future__ import annotations

import logging
import queue
import time
from collections.abc import Callable
from typing import Any

from bus_schema import topics
from handover_model import robots
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.liveliness import LivelinessWatcher
from services.runtime.node import heartbeat_period_s
from services.runtime.pubsub import TypedSubscription
from services.runtime.sched import ServiceStarvation, delivery_pids
from services.supervisor.config import SupervisorConfig
from services.supervisor.health import SELF_STALL_SETTLE_S, HealthWatch
from services.supervisor.supervision import Supervision
from services.supervisor.tick_io import Actions
from services.supervisor.truth import outcome_from_truth, simulated_robot

log = logging.getLogger(__name__)

SERVICE_NAME = "supervisor"
#: The sequencer's inputs (snapshot field, topic, queue size): they do not wake the loop, which
#: drains them at every wake-up, its ticks and the urgent ones. Each tick
#: takes only the newest message of a field into the snapshot, so a queue of one keeps only
#: that: Zenoh's ring channel drops the older ones before any Python decodes them (about
#: 120 decodes a second fewer at rest, where a 40 Hz tick finds 2–3 joint states and wrench
#: samples). The transfer targets feed a median filter: all of them are kept. On the
#: simulation clock the ring stays large (`TypedSubscription`): nothing is lost there.
TICK_INPUTS = (
    ("human", topics.HUMAN, 1), ("obj", topics.OBJECT, 1), ("target", topics.TRANSFER, 8),
    ("motion", topics.MOTION_STATUS, 1), ("gripper", topics.GRIPPER_STATE, 1),
    ("wrench", topics.WRIST_WRENCH, 1), ("joints", topics.JOINT_STATE, 1),
)


def watched_services(profile: Profile) -> list[str]:
    """Every service of the profile except the supervisor itself."""
    return [spec.name for spec in profile.services if spec.name != SERVICE_NAME]


class _Outlets:
    """The supervisor's publishers: what `Actions` asks for, the state when due, and their
    log lines."""

    def __init__(self, node: ServiceNode) -> None:
        self.goal = node.publisher(topics.MOTION_GOAL)
        self.stop = node.publisher(topics.MOTION_STOP)
        self.state = node.publisher(topics.SUPERVISOR_STATE)
        self.episode = node.publisher(topics.EPISODE)
        self.repeat_log = RateLimitedLog(log, 1.0)

    def put(self, actions: Actions, now_s: float, sup: Supervision, truth: TypedSubscription[Any] | None) -> None:
        """Publish `actions` at `now_s` (s); a summary's outcome as the newest `truth` has it."""
        if actions.stop is not None:
            self.stop.put(**actions.stop)
        if actions.goal is not None:
            self.goal.put(**actions.goal)
            ids = {k: v for k, v in actions.goal.items() if k in ("goal_id", "kind")}
            if actions.goal_repeated:
                self.repeat_log.info(ids["goal_id"], "goal sent again: no report from motion on it yet", **ids)
            else:
                log.info("goal", extra=kv(**ids))
        state = sup.state_due(actions, now_s)
        if state is not None:
            self.state.put(**state)
            if actions.state_changed:
                seq = sup.sequencer
                log.info("phase", extra=kv(phase=seq.phase, episode=seq.episode_id, reason=seq.reason))
        if actions.summary is not None:
            newest_truth = truth.latest() if truth is not None else None
            actions.summary = outcome_from_truth(actions.summary, newest_truth.msg if newest_truth else None)
            self.episode.put(**actions.summary)
            summary = actions.summary
            log.info("episode summary", extra=kv(**{k: summary[k] for k in ("episode_id", "outcome", "reason")}))


class _Inputs:
    """What the loop drains at every wake-up for the health watch and the snapshot."""

    def __init__(self, node: ServiceNode) -> None:
        self.liveliness: queue.SimpleQueue[tuple[str, bool, float]] = queue.SimpleQueue()
        self.subs = {name: node.subscribe(t, queue_size=q, wake=False) for name, t, q in TICK_INPUTS}
        # Liveness is judged on the wall clock, on the simulation clock too.
        self.heartbeats = node.subscribe(topics.HEARTBEAT, queue_size=512, wake=False, wall_time=True)

    def take(self, sup: Supervision) -> None:
        """Feed the health watch and the snapshot with everything received so far."""
        while True:
            try:
                name, alive, at_s = self.liveliness.get_nowait()
            except queue.Empty:
                break
            sup.health.liveliness(name, alive, at_s)
        for rx in self.heartbeats.drain():
            sup.health.heartbeat(rx.msg.source, rx.msg.pid, rx.rx_monotonic)
        for name, sub in self.subs.items():
            for rx in sub.drain():
                sup.take(name, sub.topic.suffix, rx.msg, rx.rx_monotonic)



def _watch(sup: Supervision, health: HealthWatch, inputs: _Inputs, now: float,
           act: Callable[[Actions, float], None], excuse_log: RateLimitedLog, stall_log: RateLimitedLog,
           sim_clock: bool = False) -> float:
    """Take the watchdog's inputs in, note a late wake of this loop (and let a starved one
    settle), and act on every fault the health watch reports (`sim_clock`: heartbeats are
    timed on the wall clock, the rest on the simulation clock's `now`). Returns the time now, s."""
    inputs.take(sup)
    stall = None if sim_clock else sup.woke(now)  # simulated time is never late
    if stall is not None:
        stall_log.warning("stall", stall.message(), late_ms=stall.late_ms)
        if stall.settle:
            time.sleep(SELF_STALL_SETTLE_S)
            inputs.take(sup)
            now = time.monotonic()
    reports = health.check(now, time.monotonic() if sim_clock else None)
    for service, why in health.excused:
        excuse_log.info(service, f"{service}: {why}")
    for report in reports:
        log.warning("service fault", extra=kv(**report.log_fields()))
        act(sup.sequencer.on_fault(now, report.fault.text(), report.critical), now)
    return now

def run_supervisor(profile: Profile, config: SupervisorConfig) -> int:
    """Run the supervisor until SIGINT/SIGTERM (or, with a finite episode count, until the
    last episode ended and the launcher stops it). Returns the exit code."""
    # One host (no other machine on the bus): a silence can be told apart as starvation.
    starvation = None if profile.allow_non_loopback else ServiceStarvation(path_pids=delivery_pids())
    health = HealthWatch(watched_services(profile), config, heartbeat_period_s(profile), starvation)
    excuse_log, stall_log = RateLimitedLog(log, 5.0), RateLimitedLog(log, 5.0)
    with ServiceNode(SERVICE_NAME, profile) as node:
        outlets = _Outlets(node)
        releases = node.subscribe(topics.GRIPPER_RELEASE, queue_size=16)
        inputs = _Inputs(node)
        # The simulation's truth decides the outcome (never control), and only where a simulated robot sends it.
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=1, wake=False) if simulated_robot(profile) else None

        def on_liveliness(name: str, alive: bool) -> None:
            inputs.liveliness.put((name, alive, node.clock.now_s()))
            node.wake_up()

        watcher = LivelinessWatcher(node.session, profile.prefix, on_change=on_liveliness)
        node.ready()
        sup = Supervision(config, health, robots.active().home_rad, node.clock.now_s())
        seq = sup.sequencer
        # Every wake-up (a release, any watched input, a liveliness change) runs an extra tick
        # at once for the release interrupt and the watchdog; the sequencer ticks on the grid.
        loop = node.rate_loop(config.rate_hz, urgent=lambda: True, urgent_per_period=None)

        def act(actions: Actions, now_s: float) -> None:
            outlets.put(actions, now_s, sup, truth)

        try:
            for _tick in loop:
                now = node.clock.now_s()
                # 1. The release interrupt first.
                for rx in releases.drain():
                    act(seq.on_release(rx.rx_monotonic, f"release event from {rx.msg.source}"), now)
                # 2. Watchdog inputs; a loop that was itself starved takes queued messages in first.
                now = _watch(sup, health, inputs, now, act, excuse_log, stall_log, node.clock.is_sim)
                if loop.urgent_tick:
                    continue
                # 3. Start when everyone is up, 4. the sequencer's tick.
                start, missing = sup.start(now)
                if start is not None:
                    act(start, now)
                if missing:
                    log.error("start failed", extra=kv(missing=missing))
                act(sup.tick(now), now)
                loop.period_s = sup.period_s()
        finally:
            watcher.undeclare()
        log.info("supervisor stopped", extra=kv(episodes=seq.episodes_done, phase=seq.phase))
    return 0
