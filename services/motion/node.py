"""Bus wiring of the motion service: goals, stops and joint states in; joint commands and the
status out. The decisions are in `core.MotionController`; which received joint state is new in
`joint_state.NewestArmState`; what goes on the bus when in `outbox.Outbox`.

In: `motion/goal`, `motion/stop`, `robot/joint_state`. Out: `robot/joint_command` (100 Hz
once a first goal has been accepted: the moving target, then the held final or stopped
position) and `motion/status` (`status_rate_hz` and on every change).

The loop ticks at `rate_hz` on the local monotonic clock. Between ticks it sleeps on the
node's data notification, and a `MotionStop` or a `MotionGoal` triggers an extra tick at
once, so a stop is acted on within the bus latency rather than up to one period later. At
rest (`MotionController.at_rest`) it ticks only when the hold command's copy is due.
`RateLoop` (services.runtime.loop) has neither the early tick nor the slower rest, so this
loop paces itself.
"""

from __future__ import annotations

import logging
import time

from bus_schema import topics
from services.motion.config import MotionConfig
from services.motion.core import MotionController
from services.motion.ik import ArmIk
from services.motion.joint_state import NewestArmState
from services.motion.outbox import Outbox
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.loop import OVERRUN_LOG_PERIOD_S
from services.runtime.repeat import HOLD_REPEAT_S

log = logging.getLogger(__name__)

SERVICE_NAME = "motion"


def run_motion(profile: Profile, config: MotionConfig) -> int:
    """Run the motion service until SIGINT/SIGTERM. Returns the exit code."""
    controller = MotionController(config, ArmIk(config))
    arm_state = NewestArmState(RateLimitedLog(log, 1.0))
    outbox = Outbox(config.status_rate_hz)
    overrun_log = RateLimitedLog(log, OVERRUN_LOG_PERIOD_S)
    period = config.period_s
    with ServiceNode(SERVICE_NAME, profile) as node:
        command_pub = node.publisher(topics.JOINT_COMMAND)
        status_pub = node.publisher(topics.MOTION_STATUS)
        goals = node.subscribe(topics.MOTION_GOAL)
        stops = node.subscribe(topics.MOTION_STOP)
        states = node.subscribe(topics.JOINT_STATE, queue_size=16, wake=False)  # read at the tick
        node.ready()
        log.info("motion running", extra=kv(rate_hz=config.rate_hz))
        next_tick = time.monotonic()
        seen_stops = seen_goals = 0
        ticks = overruns = rest_ticks = 0
        while not node.should_stop:
            now = time.monotonic()
            # A stop or a goal is taken at once; at rest nothing else needs a tick before the
            # next copy of the hold command is due.
            event_pending = stops.stats.accepted != seen_stops or goals.stats.accepted != seen_goals
            if now < next_tick and not event_pending:
                node.wait(next_tick - now)
                continue
            seen_stops, seen_goals = stops.stats.accepted, goals.stats.accepted
            if now >= next_tick:  # a periodic tick (else an extra one for a stop or a goal)
                next_tick += period
                if now > next_tick:  # overran: skip missed deadlines, no burst
                    overruns += 1
                    next_tick = now + period
                    overrun_log.info("overrun", "motion tick overran its period", overruns=overruns)
            ticks += 1
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
                next_tick = max(next_tick, now + HOLD_REPEAT_S)
        log.info("motion stopped", extra=kv(ticks=ticks, rest_ticks=rest_ticks, overruns=overruns,
                                            commands_sent=outbox.command_gate.sent,
                                            unchanged_commands_not_sent=outbox.command_gate.skipped))
    return 0
