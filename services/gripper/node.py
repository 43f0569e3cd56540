"""Bus wiring of the gripper service: wrist wrench and object motion in; gripper command,
state and the release event out. All decisions are in `services.gripper.core`.

The loop waits on the bus (`node.wait`) instead of sleeping a fixed period, so a new wrench
sample is acted on as soon as it arrives (at most `rate_hz` times a second); a watchdog tick
every 1/rate_hz notices silent sensors. Commands and release events are safety keys
(congestion control BLOCK, high priority); the state stream may drop.
"""

from __future__ import annotations

import logging
import time

from bus_schema import topics
from services.gripper.config import GripperConfig
from services.gripper.core import GripDecision, GripperCore, MotionReading, WrenchReading
from services.runtime import Profile, ServiceNode, kv

log = logging.getLogger(__name__)

SERVICE_NAME = "gripper"


def run_gripper(profile: Profile, config: GripperConfig, core: GripperCore | None = None) -> int:
    """Run the gripper service until SIGINT/SIGTERM. Returns the exit code."""
    core = core or GripperCore(config)
    with ServiceNode(SERVICE_NAME, profile) as node:
        wrench_sub = node.subscribe(topics.WRIST_WRENCH)
        motion_sub = node.subscribe(topics.OBJECT_MOTION)
        supervisor_sub = node.subscribe(topics.SUPERVISOR_STATE, queue_size=16)
        command_pub = node.publisher(topics.GRIPPER_COMMAND)
        state_pub = node.publisher(topics.GRIPPER_STATE)
        release_pub = node.publisher(topics.GRIPPER_RELEASE)
        state_period_s = 1.0 / config.state_rate_hz
        last_state_s = -1.0
        last_key: tuple | None = None
        episode_id: int | None = None
        log.info("gripper running", extra=kv(controller=config.controller, rate_hz=config.rate_hz,
                                             wrench_timeout_s=config.wrench_timeout_s))

        def publish(decision: GripDecision, now_s: float) -> None:
            nonlocal last_state_s, last_key
            command_pub.put(grip_force_n=decision.grip_force_n, position_m=decision.position_m, mode=decision.mode)
            if decision.release_event:
                release_pub.put(grip_force_n=decision.grip_force_n, pull_force_n=decision.pull_force_n,
                                controller=config.controller)
                log.info("object released", extra=kv(pull_force_n=round(decision.pull_force_n, 3)))
            key = (decision.mode, decision.sensors_fresh, decision.released, decision.reason)
            if key != last_key or now_s - last_state_s >= state_period_s:
                if key != last_key and decision.mode == "hold":
                    log.warning("holding the grip", extra=kv(reason=decision.reason))
                state_pub.put(mode=decision.mode, grip_force_n=decision.grip_force_n,
                              controller=config.controller, sensors_fresh=decision.sensors_fresh,
                              released=decision.released, reason=decision.reason)
                last_state_s, last_key = now_s, key

        while not node.should_stop:
            now_s = time.monotonic()
            node.wait(core.next_due_s(now_s))
            for rx in wrench_sub.drain():
                f = rx.msg.force_n
                core.offer_wrench(WrenchReading(force_x_n=f[0], force_y_n=f[1], rx_s=rx.rx_monotonic))
            for rx in motion_sub.drain():
                m = rx.msg
                core.offer_motion(MotionReading(accel_y_m_s2=m.accel_y_m_s2, slip_velocity_x_m_s=m.velocity_m_s[0],
                                                slip_velocity_y_m_s=m.velocity_m_s[1],
                                                surface_valid=m.surface_valid, rx_s=rx.rx_monotonic))
            core.note_rejected("wrist_wrench", wrench_sub.stats.rejected)
            core.note_rejected("object_motion", motion_sub.stats.rejected)
            if config.rearm_on_new_episode:
                for rx in supervisor_sub.drain():
                    if episode_id is not None and rx.msg.episode_id != episode_id:
                        log.info("new episode: re-arming", extra=kv(episode_id=rx.msg.episode_id))
                        core.rearm()
                    episode_id = rx.msg.episode_id
            now_s = time.monotonic()
            if node.should_stop:
                break
            if core.due(now_s):
                publish(core.tick(now_s), now_s)
        log.info("gripper stopped", extra=kv(steps=core.steps, holds=core.holds, released=core.released))
    return 0
