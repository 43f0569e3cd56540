"""Bus wiring of the bridge: joint commands in, joint state (and backend extras) out.

Loop at `rate_hz` (100 Hz): each tick hands what arrived since the last one to the `ArmLoop`
(`services.bridge.arm_loop`: commands through the `CommandGate`, stops to the `StopBrake`,
the backend stepped, servoing or holding) and publishes `robot/joint_state` and the backend's
extras.

A `motion/stop` (release interrupt or protective stop) is acted on here too, without the
motion service. The stop does not wait for the next tick: its arrival wakes the loop
(`ServiceNode.rate_loop` with an urgent predicate), which runs a tick at once with the real
elapsed dt, so the joint state with the brake engaged is published within about a
millisecond. A new supervisor episode resets a simulated scene.

The simulated Kinect is not here (it renders in the tracker, or as its own service), so its
depth frames do not delay this loop through the GIL.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from bus_schema import topics
from services.bridge.arm_loop import ArmLoop, Inbox
from services.bridge.backend import Backend, make_backend
from services.bridge.config import BridgeConfig
from services.bridge.errors import BridgeConfigError
from services.runtime import Profile, ServiceNode, kv
from services.runtime.clock import clock_source
from services.runtime.liveliness import LivelinessWatcher

log = logging.getLogger(__name__)

SERVICE_NAME = "bridge"


def _backend_for(profile: Profile, config: BridgeConfig) -> Backend:
    """The backend `config` names, built before the bridge joins the bus."""
    initial = np.array(config.initial_position_rad) if config.initial_position_rad else None
    return make_backend(
        config.backend, contact=config.contact, time_constant_s=config.servo_time_constant_s,
        initial_position_rad=initial, robot_command_timeout_s=config.sim_robot_command_timeout_s,
        profile=profile, baxter=config.baxter, franka=config.franka,
    )


def run_bridge(profile: Profile, config: BridgeConfig, backend: Backend | None = None) -> int:
    """Run the bridge until SIGINT/SIGTERM. Returns the exit code."""
    backend = backend or _backend_for(profile, config)
    owns_clock = clock_source(profile.clock) == "sim"
    if owns_clock and backend.name != "sim":
        raise BridgeConfigError(f"the simulation clock is owned by the bridge's simulation, but its backend is "
                          f"{backend.name!r}: run this profile on the wall clock (handover-up --clock wall)")
    with ServiceNode(SERVICE_NAME, profile, clock_role="owner" if owns_clock else "participant") as node:
        clock = node.clock
        state_pub = node.publisher(topics.JOINT_STATE)
        # Read at the servo's tick; only a stop wakes the loop early (`ServiceNode.rate_loop`).
        commands = node.subscribe(topics.JOINT_COMMAND, wake=False)
        grips = node.subscribe(topics.GRIPPER_COMMAND, wake=False)
        stops = node.subscribe(topics.MOTION_STOP, queue_size=16)
        inbox = Inbox(stops=stops, goals=node.subscribe(topics.MOTION_GOAL, queue_size=64, wake=False),
                      supervisor=node.subscribe(topics.SUPERVISOR_STATE, queue_size=16, wake=False),
                      commands=commands, grips=grips)
        stop_pub = node.publisher(topics.MOTION_STOP)
        arm = ArmLoop(backend, config, start_s=clock.now_s())

        def on_liveliness(name: str, alive: bool) -> None:
            if name == "supervisor":  # a Zenoh thread: record, and wake the loop
                arm.supervisor_loss.token(alive)
                node.wake_up()

        watcher = LivelinessWatcher(node.session, profile.prefix, on_change=on_liveliness)
        node.ready()
        extra_pubs: dict[str, Any] = {}

        def publish_extra(suffix: str, fields: dict[str, Any]) -> None:
            pub = extra_pubs.get(suffix)
            if pub is None:
                pub = extra_pubs[suffix] = node.publisher(topics.TOPICS_BY_SUFFIX[suffix])
            pub.put(**fields)

        log.info("bridge running", extra=kv(backend=backend.name, rate_hz=config.rate_hz,
                                            command_timeout_s=config.command_timeout_s,
                                            stop_wakes_loop=config.stop_wakes_loop))

        def stop_pending() -> bool:
            if arm.supervisor_loss.pending():
                return True
            latest = stops.latest()
            return latest is not None and latest is not arm.newest_stop

        loop = node.rate_loop(config.rate_hz, urgent=stop_pending if config.stop_wakes_loop else None)
        try:
            for _tick in loop:
                state_pub.put(**arm.tick(clock.now_s(), inbox))
                own_stop = arm.take_own_stop()
                if own_stop is not None:
                    stop_pub.put(reason=f"protective stop: {own_stop}", protective=True)
                arm.publish_extras(publish_extra, clock.now_s())
        finally:
            watcher.undeclare()
            backend.close()
            log.info("bridge stopped", extra=kv(accepted=arm.gate.accepted, rejected=arm.gate.rejected,
                                                ignored_after_stop=arm.brake.ignored_commands,
                                                ticks=loop.stats.ticks, stop_ticks=loop.stats.urgent_ticks,
                                                unchanged_truth_not_sent=arm.truth_gate.skipped,
                                                supervisor_lost_stops=arm.supervisor_loss.stops,
                                                overruns=loop.stats.overruns))
    return 0
