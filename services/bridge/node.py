"""Bus wiring of the bridge: joint commands in, joint state (and backend extras) out.

Loop at `rate_hz` (100 Hz): take every joint command received since the last tick through
the `CommandGate`, step the backend, servo or hold, publish `robot/joint_state`.

A `motion/stop` (release interrupt or protective stop) is acted on here too, without the
motion service: the `StopBrake` brings the arm to rest with a bounded deceleration and
ignores the stopped goal's commands. The stop does not wait for the next tick: its arrival
wakes the loop (`RateLoop` with an urgent predicate), which runs a tick at once with the real elapsed dt, so the
joint state with the brake engaged is published within about a millisecond. A new
supervisor episode resets a simulated scene.

The simulated Kinect is not here (it renders in the tracker, or as its own service), so its
depth frames do not delay this loop through the GIL. `sim/truth` goes out when it changed
by more than 1 nm (`settled_key`), or every `TRUTH_REPEAT_S` at rest.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from bus_schema import topics
from services.bridge.backend import Backend, make_backend
from services.bridge.config import BridgeConfig
from services.bridge.core import CommandGate, StopBrake
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.repeat import RepeatGate, settled_key

log = logging.getLogger(__name__)

SERVICE_NAME = "bridge"
#: A tick later than this many periods is a stall the backend catches up on (`Backend.catch_up`).
STALL_PERIODS = 2.0
#: `sim/truth` goes out on every tick where any of its values changed, and otherwise again
#: this often, s. The simulation's truth at rest (the object in the receiver's hand, the arm
#: still) is the same message 100 times a second, each crossing the router to the launcher and
#: the recorder (and the tracker's simulated Kinect): issue 16. Its readers take the newest
#: value, so an unchanged one need not be repeated; every change still goes out at once.
TRUTH_REPEAT_S = 0.1


def run_bridge(profile: Profile, config: BridgeConfig, backend: Backend | None = None) -> int:
    """Run the bridge until SIGINT/SIGTERM. Returns the exit code."""
    initial = np.array(config.initial_position_rad) if config.initial_position_rad else None
    backend = backend or make_backend(
        config.backend, contact=config.contact, time_constant_s=config.servo_time_constant_s,
        initial_position_rad=initial, robot_command_timeout_s=config.sim_robot_command_timeout_s,
        profile=profile, baxter=config.baxter,
    )
    gate = CommandGate(backend.joint_names, backend.limits, config.command_timeout_s,
                       config.limit_tolerance_rad)
    reject_log = RateLimitedLog(log, 1.0)
    brake = StopBrake(config.stop_deceleration_rad_s2)
    new_episode = getattr(backend, "new_episode", None)
    with ServiceNode(SERVICE_NAME, profile) as node:
        state_pub = node.publisher(topics.JOINT_STATE)
        # Read at the servo's tick; only a stop wakes the loop early (`ServiceNode.rate_loop`).
        commands = node.subscribe(topics.JOINT_COMMAND, wake=False)
        grip_commands = node.subscribe(topics.GRIPPER_COMMAND, wake=False)
        stops = node.subscribe(topics.MOTION_STOP, queue_size=16)
        goals = node.subscribe(topics.MOTION_GOAL, queue_size=64, wake=False)
        supervisor = node.subscribe(topics.SUPERVISOR_STATE, queue_size=16, wake=False)
        node.ready()
        episode_id: int | None = None
        extra_pubs: dict[str, Any] = {}

        truth_gate = RepeatGate(TRUTH_REPEAT_S)

        def publish_extra(suffix: str, fields: dict[str, Any]) -> None:
            if suffix == topics.SIM_TRUTH.suffix and not truth_gate.due(settled_key(fields.values()), time.monotonic()):
                return
            pub = extra_pubs.get(suffix)
            if pub is None:
                pub = extra_pubs[suffix] = node.publisher(topics.TOPICS_BY_SUFFIX[suffix])
            pub.put(**fields)

        handled_stop: list[Any] = [None]  # the newest stop drained so far

        def stop_pending() -> bool:
            latest = stops.latest()
            return latest is not None and latest is not handled_stop[0]

        ticker = node.rate_loop(config.rate_hz, urgent=stop_pending if config.stop_wakes_loop else None)
        log.info("bridge running", extra=kv(backend=backend.name, rate_hz=config.rate_hz,
                                            command_timeout_s=config.command_timeout_s,
                                            stop_wakes_loop=config.stop_wakes_loop))
        last_s = time.monotonic()
        was_holding = True
        try:
            for _tick in ticker:
                now_s = time.monotonic()
                dt_s, last_s = now_s - last_s, now_s
                if dt_s > STALL_PERIODS * ticker.period_s:
                    # The loop stalled: the robot did not wait for it. Live through the gap
                    # under the old command before this tick's stops and commands act.
                    backend.catch_up(dt_s - ticker.period_s)
                    if brake.active:
                        brake.step(dt_s - ticker.period_s)  # the brake's ramp went on too
                    dt_s = ticker.period_s
                measured = backend.read()
                current = measured.position_rad
                new_stops = stops.drain()
                if new_stops:
                    handled_stop[0] = new_stops[-1]
                # Stops and goals in arrival order; a goal ends a stop only if sent after it
                # (by the stamps when both come from one source, `StopBrake.goal_after_stop`).
                events = sorted([(rx.rx_monotonic, 0, rx) for rx in new_stops]
                                + [(rx.rx_monotonic, 1, rx) for rx in goals.drain()], key=lambda e: (e[0], e[1]))
                for _t, kind, rx in events:
                    if kind == 1:
                        brake.goal_after_stop(rx.msg.goal_id, rx.msg.source, rx.msg.stamp_ns)
                        continue
                    if not brake.active:  # a release stop is the normal handover; a protective one is not
                        log.log(logging.WARNING if rx.msg.protective else logging.INFO, "stop: braking",
                                extra=kv(reason=rx.msg.reason, protective=rx.msg.protective, source=rx.msg.source))
                    brake.engage(rx.msg.reason, measured.velocity_rad_s, rx.msg.protective,
                                 rx.msg.source, rx.msg.stamp_ns)
                for rx in supervisor.drain():
                    if episode_id is not None and rx.msg.episode_id != episode_id:
                        brake.new_episode()
                        if new_episode is not None:
                            log.info("new episode: scene reset", extra=kv(episode_id=rx.msg.episode_id))
                            new_episode()
                    episode_id = rx.msg.episode_id
                for rx in commands.drain():
                    if not brake.admit(rx.msg.goal_id):
                        continue
                    reason = gate.offer(rx.msg.names, rx.msg.position_rad, rx.rx_monotonic, current,
                                        rx.msg.velocity_rad_s)
                    if reason is not None:
                        reject_log.warning("rejected", f"joint command rejected, holding: {reason}",
                                           source=rx.msg.source, seq=rx.msg.seq)
                grips = grip_commands.drain()
                if grips:
                    backend.gripper_command(grips[-1].msg.grip_force_n)
                decision = gate.decide(now_s)
                if brake.active:
                    velocity = brake.step(dt_s)
                    if brake.at_rest:
                        backend.hold()
                    else:
                        backend.command(current, velocity)
                    holding = True
                elif decision.holding:
                    backend.hold()
                    if not was_holding:
                        log.info("arm holding", extra=kv(reason=decision.reason))
                else:
                    backend.command(decision.target_rad, decision.feedforward_rad_s)
                if not brake.active:
                    holding = decision.holding
                was_holding = holding
                backend.step(dt_s)
                reading = backend.read()
                state_pub.put(
                    names=list(backend.joint_names),
                    position_rad=reading.position_rad.tolist(),
                    velocity_rad_s=reading.velocity_rad_s.tolist(),
                    effort_nm=reading.effort_nm.tolist(),
                    holding=holding,
                    backend=backend.name,
                    enabled=bool(getattr(backend, "enabled", True)),
                )
                backend.publish_extras(publish_extra)
        finally:
            backend.close()
            log.info("bridge stopped", extra=kv(accepted=gate.accepted, rejected=gate.rejected,
                                                ignored_after_stop=brake.ignored_commands,
                                                ticks=ticker.stats.ticks, stop_ticks=ticker.stats.urgent_ticks,
                                                unchanged_truth_not_sent=truth_gate.skipped,
                                                overruns=ticker.stats.overruns))
    return 0
