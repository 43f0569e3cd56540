"""Bus wiring of the motion service: goals, stops and joint states in; joint commands and the
status out. The decisions are in `core.MotionController`; which received joint state is new in
`joint_state.NewestArmState`; what goes on the bus when in `outbox.Outbox`.

In: `motion/goal`, `motion/stop`, `robot/joint_state`. Out: `robot/joint_command` (100 Hz
once a first goal has been accepted: the moving target, then the held final or stopped
position) and `motion/status` (`status_rate_hz` and on every change).

The loop is the stack's `RateLoop` (services.runtime.loop) at `rate_hz`. Between ticks it
sleeps on the node's data notification, and a `MotionStop` or a `MotionGoal` runs an extra
tick at once, so a stop is acted on within the bus latency rather than up to one period later.
At rest (`MotionController.at_rest`) the loop rests until the hold command's copy is due
(`RateLoop.rest_until`).
"""

from __future__ import annotations

import logging

from bus_schema import topics
from services.motion.config import MotionConfig
from services.motion.core import MotionController
from services.motion.ik import ArmIk
from services.motion.joint_state import NewestArmState
from services.motion.outbox import Outbox
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.repeat import HOLD_REPEAT_S

log = logging.getLogger(__name__)

SERVICE_NAME = "motion"


def run_motion(profile: Profile, config: MotionConfig) -> int:
    """Run the motion service until SIGINT/SIGTERM. Returns the exit code."""
    controller = MotionController(config, ArmIk(config))
    arm_state = NewestArmState(RateLimitedLog(log, 1.0))
    outbox = Outbox(config.status_rate_hz)
    with ServiceNode(SERVICE_NAME, profile) as node:
        command_pub = node.publisher(topics.JOINT_COMMAND)
        status_pub = node.publisher(topics.MOTION_STATUS)
        goals = node.subscribe(topics.MOTION_GOAL)
        stops = node.subscribe(topics.MOTION_STOP)
        # Read at the tick, the newest only: older samples are dropped by Zenoh, undecoded.
        states = node.subscribe(topics.JOINT_STATE, queue_size=1, wake=False)
        node.ready()
        log.info("motion running", extra=kv(rate_hz=config.rate_hz))
        seen = [0, 0]  # stops and goals accepted when the last tick ran

        def event_pending() -> bool:
            """A stop or a goal came since the last tick: it is taken at once."""
            return stops.stats.accepted != seen[0] or goals.stats.accepted != seen[1]

        loop = node.rate_loop(config.rate_hz, urgent=event_pending)
        rest_ticks = 0
        for _tick in loop:
            now = node.clock.now_s()
            seen[:] = [stops.stats.accepted, goals.stats.accepted]
            states.drain()
            measured = arm_state.take(states.latest())
            if measured is not None:
                controller.note_measurement(measured)
            out = controller.step(now, goals=[r.msg for r in goals.drain()], stops=[r.msg for r in stops.drain()])
            command = outbox.command(out, now)
            if command is not None:
                command_pub.put(**command)
            status = outbox.status(out, now)
            if status is not None:
                status_pub.put(**status)
            if controller.at_rest:  # holding still: tick again when the hold's copy is due
                rest_ticks += 1
                loop.rest_until(now + HOLD_REPEAT_S)
        log.info("motion stopped", extra=kv(ticks=loop.stats.ticks + loop.stats.urgent_ticks, rest_ticks=rest_ticks,
                                            overruns=loop.stats.overruns,
                                            commands_sent=outbox.command_gate.sent,
                                            unchanged_commands_not_sent=outbox.command_gate.skipped))
    return 0
