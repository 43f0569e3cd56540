"""Bus wiring of the motion service.

In: `motion/goal`, `motion/stop`, `robot/joint_state`. Out: `robot/joint_command` (100 Hz
once a first goal has been accepted: the moving target, then the held final or stopped
position) and `motion/status` (`status_rate_hz` and on every change).

The loop ticks at `rate_hz` on the local monotonic clock. Between ticks it sleeps on the
node's data notification, and a `MotionStop` triggers an extra tick at once, so a stop is
acted on within the bus latency rather than up to one period later.
"""

from __future__ import annotations

import logging
import time

from bus_schema import topics
from robot_sim.baxter import RIGHT_ARM_JOINTS
from services.motion.config import MotionConfig
from services.motion.core import MotionController
from services.motion.errors import MotionError
from services.motion.ik import ArmIk
from services.motion.joint_state import arm_positions_from
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.loop import OVERRUN_LOG_PERIOD_S
from services.runtime.repeat import HOLD_REPEAT_S, RepeatGate

log = logging.getLogger(__name__)

SERVICE_NAME = "motion"


def run_motion(profile: Profile, config: MotionConfig) -> int:
    """Run the motion service until SIGINT/SIGTERM. Returns the exit code."""
    controller = MotionController(config, ArmIk(config))
    bad_state_log = RateLimitedLog(log, 1.0)
    overrun_log = RateLimitedLog(log, OVERRUN_LOG_PERIOD_S)
    period = config.period_s
    status_every_s = 1.0 / config.status_rate_hz
    joint_names = list(RIGHT_ARM_JOINTS)
    with ServiceNode(SERVICE_NAME, profile) as node:
        command_pub = node.publisher(topics.JOINT_COMMAND)
        status_pub = node.publisher(topics.MOTION_STATUS)
        goals = node.subscribe(topics.MOTION_GOAL)
        stops = node.subscribe(topics.MOTION_STOP)
        states = node.subscribe(topics.JOINT_STATE, queue_size=16, wake=False)  # read at the tick
        node.ready()
        log.info("motion running", extra=kv(rate_hz=config.rate_hz))
        last_state = None
        next_tick = time.monotonic()
        last_status_s = -float("inf")
        command_gate = RepeatGate()
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
            periodic = now >= next_tick
            if periodic:
                next_tick += period
                if now > next_tick:  # overran: skip missed deadlines, no burst
                    overruns += 1
                    next_tick = now + period
                    overrun_log.info("overrun", "motion tick overran its period", overruns=overruns)
            ticks += 1
            states.drain()
            latest = states.latest()
            measured_q = measured_dq = None
            measured_at = None
            if latest is not None and latest is not last_state:
                last_state = latest
                try:
                    measured_q = arm_positions_from(latest.msg.names, latest.msg.position_rad)
                    if len(latest.msg.velocity_rad_s) == len(latest.msg.names):
                        measured_dq = arm_positions_from(latest.msg.names, latest.msg.velocity_rad_s)
                    measured_at = latest.rx_monotonic
                except MotionError as exc:
                    bad_state_log.warning("joint_state", f"ignoring joint state: {exc}")
            out = controller.step(
                now,
                measured_q,
                [r.msg for r in goals.drain()],
                [r.msg for r in stops.drain()],
                measured_dq_rad_s=measured_dq,
                measured_at_s=measured_at,
            )
            if out.command_q_rad is not None:
                position = out.command_q_rad.tolist()
                velocity = out.command_dq_rad_s.tolist()
                # Moving: every tick. Holding still: on a change, else a copy every 50 ms.
                if command_gate.due((*position, out.goal_id), now, always=any(velocity)):
                    command_pub.put(names=joint_names, position_rad=position, velocity_rad_s=velocity,
                                    goal_id=out.goal_id)
            if out.status_changed or now - last_status_s >= status_every_s:
                st = out.status
                status_pub.put(
                    goal_id=st.goal_id,
                    state=st.state,
                    reason=st.reason,
                    progress=st.progress,
                    tool_speed_m_s=st.tool_speed_m_s,
                )
                last_status_s = now
            if controller.at_rest:  # holding still: tick again when the hold's copy is due
                rest_ticks += 1
                next_tick = max(next_tick, now + HOLD_REPEAT_S)
        log.info("motion stopped", extra=kv(ticks=ticks, rest_ticks=rest_ticks, overruns=overruns,
                                            commands_sent=command_gate.sent,
                                            unchanged_commands_not_sent=command_gate.skipped))
    return 0
