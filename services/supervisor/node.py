"""Bus wiring of the supervisor: everything in, motion goals / stops / state / summaries out.

The loop sleeps on the bus between 100 Hz ticks (`node.wait`; 40 Hz once the last episode
has ended, `RESTING_PERIOD_S`), so a release event is acted on as soon as it arrives (the
stop goes out before anything else is looked at), not at the next tick. Liveliness changes
arrive on a Zenoh thread and are queued; heartbeats and the watched data streams are drained
every wake-up. All decisions are in `core.Sequencer` and `watchdog.Watchdog`.
"""

from __future__ import annotations

import logging
import queue
import time
from bus_schema import topics
from robot_sim.baxter import RIGHT_ARM_HOME_RAD
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.liveliness import LivelinessWatcher
from services.runtime.node import heartbeat_period_s
from services.runtime.sched import MAX_EXCUSED_S, ServiceStarvation, delivery_pids
from services.supervisor.config import SupervisorConfig
from services.supervisor.core import Sequencer
from services.supervisor.targets import TargetFilter
from services.supervisor.tick_io import Actions, Snapshot
from services.supervisor.truth import outcome_from_truth, simulated_robot
from services.supervisor.watchdog import Watchdog, judging_for_beats, resolve_heartbeat_timeout_s

log = logging.getLogger(__name__)
#: A loop iteration this much later than the previous one means the supervisor itself was
#: starved: before calling a service silent it lets queued messages in for `SELF_STALL_SETTLE_S`.
SELF_STALL_S = 0.05
SELF_STALL_SETTLE_S = 0.01
#: A loop iteration this much late is logged even when nobody looked silent: the release
#: interrupt and every watchdog waited that long (at most one line per 5 s).
SELF_STALL_REPORT_S = 0.2

SERVICE_NAME = "supervisor"
#: Data streams whose silence means their service is silent (topic → owner): fixed-rate
#: streams of the services that touch the robot. The motion service's status pauses while it
#: plans a reach (tens of ms), so the motion service is judged by its heartbeat, which its
#: planner keeps sending.
WATCHED_STREAMS = {
    topics.JOINT_STATE.suffix: "bridge",
    topics.GRIPPER_STATE.suffix: "gripper",
}
#: supervisor/state is published at least this often, s.
STATE_PERIOD_S = 0.05
#: Tick period once the last episode has ended (`Sequencer.resting`), s: nothing but the
#: watchdog can act then. Half the state period, so the state still goes out every 50 ms;
#: a release or a liveliness change wakes the loop at once whatever the period, and a
#: killed or stopped service is still seen within 100 ms (DESIGN §8).
RESTING_PERIOD_S = STATE_PERIOD_S / 2
#: A tick this close before the state is due sends it (a tick a hair early would otherwise
#: push the state one whole tick late), s.
STATE_EARLY_S = 0.004


def watched_services(profile: Profile) -> list[str]:
    """Every service of the profile except the supervisor itself."""
    return [spec.name for spec in profile.services if spec.name != SERVICE_NAME]


def run_supervisor(profile: Profile, config: SupervisorConfig) -> int:
    """Run the supervisor until SIGINT/SIGTERM (or, with a finite episode count, until the
    last episode ended and the launcher stops it). Returns the exit code."""
    services = watched_services(profile)
    # One host (no other machine on the bus): a silence can be told apart as starvation.
    starvation = None if profile.allow_non_loopback else ServiceStarvation(path_pids=delivery_pids())
    beat_period_s = heartbeat_period_s(profile)
    heartbeat_timeout_s = resolve_heartbeat_timeout_s(config.heartbeat_timeout_s, beat_period_s)
    watchdog = Watchdog(services, heartbeat_timeout_s, config.stream_timeout_s,
                        {s: o for s, o in WATCHED_STREAMS.items() if o in services},
                        {name: config.report_heartbeat_timeout_s for name in services
                         if config.watch.get(name) == "report"},
                        excuser=starvation, max_excused_s=MAX_EXCUSED_S, **judging_for_beats(beat_period_s))
    excuse_log = RateLimitedLog(log, 5.0)
    sequencer = Sequencer(config, RIGHT_ARM_HOME_RAD)
    liveliness_events: queue.SimpleQueue[tuple[str, bool, float]] = queue.SimpleQueue()
    with ServiceNode(SERVICE_NAME, profile) as node:
        goal_pub = node.publisher(topics.MOTION_GOAL)
        stop_pub = node.publisher(topics.MOTION_STOP)
        state_pub = node.publisher(topics.SUPERVISOR_STATE)
        episode_pub = node.publisher(topics.EPISODE)
        releases = node.subscribe(topics.GRIPPER_RELEASE, queue_size=16)
        # Read at the 100 Hz tick: only a release event (and a liveliness change) wakes the loop.
        subs = {name: node.subscribe(t, queue_size=q, wake=False) for name, t, q in (
            ("human", topics.HUMAN, 8), ("obj", topics.OBJECT, 8), ("target", topics.TRANSFER, 8),
            ("motion", topics.MOTION_STATUS, 64), ("gripper", topics.GRIPPER_STATE, 64),
            ("wrench", topics.WRIST_WRENCH, 64), ("joints", topics.JOINT_STATE, 64),
        )}
        heartbeats = node.subscribe(topics.HEARTBEAT, queue_size=512, wake=False)
        # The simulation's truth decides the outcome (never control), and only where a simulated robot sends it.
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=1, wake=False) if simulated_robot(profile) else None

        def on_liveliness(name: str, alive: bool) -> None:
            liveliness_events.put((name, alive, time.monotonic()))
            node.wake_up()

        watcher = LivelinessWatcher(node.session, profile.prefix, on_change=on_liveliness)
        node.ready()
        snap = Snapshot(now_s=time.monotonic())
        targets = TargetFilter()
        ready_since: float | None = None
        started_s = time.monotonic()
        last_state_s = -1.0
        repeat_log = RateLimitedLog(log, 1.0)

        def act(actions: Actions, now_s: float) -> None:
            nonlocal last_state_s
            if actions.stop is not None:
                stop_pub.put(**actions.stop)
            if actions.goal is not None:
                goal_pub.put(**actions.goal)
                ids = {k: v for k, v in actions.goal.items() if k in ("goal_id", "kind")}
                if actions.goal_repeated:
                    repeat_log.info(ids["goal_id"], "goal sent again: no report from motion on it yet", **ids)
                else:
                    log.info("goal", extra=kv(**ids))
            if actions.state_changed or now_s - last_state_s >= STATE_PERIOD_S - STATE_EARLY_S:
                state_pub.put(phase=sequencer.phase, episode_id=sequencer.episode_id,
                              reason=sequencer.reason[:512], elapsed_s=min(sequencer.elapsed_s(now_s), 86400.0),
                              grip_request=sequencer.grip_request)
                last_state_s = now_s
                if actions.state_changed:
                    log.info("phase", extra=kv(phase=sequencer.phase, episode=sequencer.episode_id,
                                               reason=sequencer.reason))
            if actions.summary is not None:
                newest_truth = truth.latest() if truth is not None else None
                actions.summary = outcome_from_truth(actions.summary, newest_truth.msg if newest_truth else None)
                episode_pub.put(**actions.summary)
                log.info("episode summary",
                         extra=kv(**{k: actions.summary[k] for k in ("episode_id", "outcome", "reason")}))

        def take_inputs() -> None:
            """Feed the watchdog and the snapshot with everything received so far."""
            while True:
                try:
                    name, alive, at_s = liveliness_events.get_nowait()
                except queue.Empty:
                    break
                watchdog.liveliness(name, alive, at_s)
            for rx in heartbeats.drain():
                watchdog.heartbeat(rx.msg.source, rx.rx_monotonic)
                if starvation is not None:
                    starvation.heard(rx.msg.source, rx.msg.pid)
            for name, sub in subs.items():
                for rx in sub.drain():
                    setattr(snap, name, rx.msg)
                    if hasattr(snap, f"{name}_rx_s"):
                        setattr(snap, f"{name}_rx_s", rx.rx_monotonic)
                    if name == "target":
                        targets.offer(rx.msg, rx.rx_monotonic)
                    watchdog.stream(sub.topic.suffix, rx.rx_monotonic)

        stall_log = RateLimitedLog(log, 5.0)
        next_tick = last_loop_s = time.monotonic()
        try:
            while not node.should_stop:
                node.wait(max(0.0, next_tick - time.monotonic()))
                now = time.monotonic()
                # 1. The release interrupt first.
                for rx in releases.drain():
                    act(sequencer.on_release(rx.rx_monotonic, f"release event from {rx.msg.source}"), now)
                # 2. Watchdog inputs.
                take_inputs()
                stalled_s, last_loop_s = now - last_loop_s, now
                if stalled_s > SELF_STALL_S and any(f.what == "silent" for f in watchdog.pending(now)):
                    # This loop itself was late (starved of CPU): what the others sent meanwhile
                    # may still wait for this process's callback threads. Let it in before
                    # calling anyone silent.
                    stall_log.warning("stall", f"supervisor loop was {stalled_s * 1e3:.0f} ms late: "
                                               "taking queued messages in before judging freshness",
                                      late_ms=round(stalled_s * 1e3))
                    time.sleep(SELF_STALL_SETTLE_S)
                    take_inputs()
                    now = time.monotonic()
                elif stalled_s > SELF_STALL_REPORT_S:
                    # Late, but the callback threads had already let everything in: nothing to
                    # wait for, still worth saying (the release interrupt waited this long too).
                    stall_log.warning("stall", f"supervisor loop was {stalled_s * 1e3:.0f} ms late "
                                               "(starved of CPU?); no service looked silent",
                                      late_ms=round(stalled_s * 1e3))
                faults = watchdog.check(now)
                for service, why in watchdog.excused:
                    excuse_log.info(service, f"{service}: {why}")
                for fault in faults:
                    critical = config.watch.get(fault.service, "critical") == "critical"
                    starved = (starvation.explain(fault.service)
                               if starvation is not None and fault.what == "silent" else "n/a")
                    log.warning("service fault", extra=kv(service=fault.service, what=fault.what,
                                                          detail=fault.detail, critical=critical,
                                                          notice_latency_s=round(fault.noticed_s - fault.since_s, 4),
                                                          starvation=starved))
                    act(sequencer.on_fault(now, fault.text(), critical), now)
                if now < next_tick:
                    continue
                period_s = max(RESTING_PERIOD_S, config.period_s) if sequencer.resting else config.period_s
                next_tick += period_s
                if next_tick < now:
                    next_tick = now + period_s  # late: do not burst
                # 3. Start when everyone is up.
                if sequencer.phase == "idle" and sequencer.episode is None:
                    if watchdog.all_alive():
                        ready_since = ready_since or now
                        if now - ready_since >= config.start_delay_s:
                            act(sequencer.start_episode(now), now)
                    elif now - started_s > config.start_timeout_s:
                        sequencer.reason = f"services not alive: {', '.join(watchdog.missing())}"
                        log.error("start failed", extra=kv(missing=watchdog.missing()))
                # 4. The sequencer's tick.
                snap.now_s = now
                snap.target = targets.current(now)
                act(sequencer.tick(snap), now)
        finally:
            watcher.undeclare()
        log.info("supervisor stopped", extra=kv(episodes=sequencer.episodes_done, phase=sequencer.phase))
    return 0

