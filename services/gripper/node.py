"""Bus wiring of the gripper service: wrist wrench and object motion in; gripper command,
state and the release event out. All decisions are in `services.gripper.core`.

Latency path (DESIGN §9: sensor sample in → grip command out, p99 ≤ 1 ms). Default: the
runtime's subscriptions decode each payload in Zenoh's thread and wake the main thread,
which steps the controller and publishes the command (it waits on the bus, not on a timer).
That holds while it releases; at rest the wrench subscription rests too (`wakes_loop`): its
samples wait in a ring channel, read at the 50 ms hold tick, and no Python runs per sample.
`step_in_callback = true` instead runs a due step and publishes its command inside the
wrist-wrench callback, saving that thread wake-up; measured side by side
(tests/bench/test_bench_gripper_bus.py) it gains nothing on the median and nothing reliable
on p99, so it is off (a blocking publish inside Zenoh's receive thread can also stall
reception). A lock serialises the core between the callbacks and the main thread. Each
process logs, at exit, the median and p99 of "wrench received → command published".

The main thread also runs the watchdog: a tick every 1/rate_hz judges freshness even when
the sensors go silent (then the service holds), re-arms on a new supervisor episode and
sends the heartbeat. A supervisor state wakes it only when the episode or the grip request
changed (`SupervisorWord`); the others, 20 a second at rest, are read at its next tick. Commands and
release events are safety keys (congestion control BLOCK, high priority); the state stream
may drop.

Undecodable payloads are dropped at the edge (counted, named in the state's reason).
"""

from __future__ import annotations

import logging
import os
import re
import threading
import time
from collections import deque

import numpy as np
import zenoh

from bus_schema import decode, topics
from bus_schema.codec import DecodeError
from services.gripper.config import GripperConfig
from services.gripper.core import GripDecision, GripperCore, MotionReading, WrenchReading
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.runtime.clock import CLOCK_ENV, PARTICIPANT_PHASE_S, first_grid_time_s
from services.runtime.repeat import HOLD_REPEAT_S, RepeatGate

log = logging.getLogger(__name__)

SERVICE_NAME = "gripper"
#: The main thread wakes at least this often, s (the heartbeat has its own thread; a shutdown
#: and a supervisor state with a new episode or grip request wake it at once).
_MAX_WAIT_S = HOLD_REPEAT_S
#: Latency samples kept for the exit log (wrench receive → command published).
_LATENCY_WINDOW = 20_000
#: At most one "holding the grip" warning per kind of reason per this many seconds.
HOLD_LOG_PERIOD_S = 2.0


class _GripperIO:
    """The gripper's bus side, shared by the Zenoh callbacks and the main thread under one
    lock: sensor samples in (decoded, handed to the core), command, state and release out.
    (The loop's timing is the core's: `GripperCore.due` and `next_due_s`.)"""

    def __init__(self, node: ServiceNode, config: GripperConfig, core: GripperCore) -> None:
        self.node, self.config, self.core = node, config, core
        self.lock = threading.Lock()
        self.command_pub = node.publisher(topics.GRIPPER_COMMAND)
        self.state_pub = node.publisher(topics.GRIPPER_STATE)
        self.release_pub = node.publisher(topics.GRIPPER_RELEASE)
        self.command_gate = RepeatGate()  # open/carry/hold: the same command is not re-sent at 100 Hz
        self.state_period_s = 1.0 / config.state_rate_hz
        self.last_state_s = -1.0
        self.last_key: tuple | None = None
        self.rejected = {"wrist_wrench": 0, "object_motion": 0}
        self.latency_s: deque[float] = deque(maxlen=_LATENCY_WINDOW)
        self._bad_log_s = -1.0
        self.hold_log = RateLimitedLog(log, HOLD_LOG_PERIOD_S)

    # ------------------------------------------------------------------ Zenoh threads
    def _decode(self, stream: str, topic, sample: zenoh.Sample):
        try:
            return decode(topic, sample.payload.to_bytes())
        except (DecodeError, ValueError, TypeError) as exc:
            with self.lock:
                self.rejected[stream] += 1
                self.core.note_rejected(stream, self.rejected[stream])
            now = time.monotonic()
            if now - self._bad_log_s > 1.0:
                self._bad_log_s = now
                log.warning("dropped undecodable payload", extra=kv(stream=stream, error=str(exc)[:120],
                                                                    rejected=self.rejected[stream]))
            return None

    def on_wrench(self, sample: zenoh.Sample) -> None:
        rx_s = time.monotonic()
        msg = self._decode("wrist_wrench", topics.WRIST_WRENCH, sample)
        if msg is None:
            return
        f = msg.force_n
        try:
            with self.lock:
                self.core.offer_wrench(WrenchReading(force_x_n=f[0], force_y_n=f[1], rx_s=rx_s))
                now_s = time.monotonic()
                if self.core.due(now_s) and not self.node.should_stop:
                    self.publish(self.core.tick(now_s), now_s, rx_s)
        except Exception:  # never let anything escape into Zenoh's thread; the watchdog holds
            log.exception("gripper step in the sensor callback failed")

    def on_motion(self, sample: zenoh.Sample) -> None:
        rx_s = time.monotonic()
        m = self._decode("object_motion", topics.OBJECT_MOTION, sample)
        if m is None:
            return
        reading = MotionReading(accel_y_m_s2=m.accel_y_m_s2, slip_velocity_x_m_s=m.velocity_m_s[0],
                                slip_velocity_y_m_s=m.velocity_m_s[1], surface_valid=m.surface_valid, rx_s=rx_s)
        with self.lock:
            self.core.offer_motion(reading)

    # ------------------------------------------------------------------ output (lock held)
    def publish(self, decision: GripDecision, now_s: float, rx_s: float | None = None) -> None:
        command = (decision.grip_force_n, decision.position_m, decision.mode)
        if self.command_gate.due(command, now_s, always=decision.stepped or decision.release_event):
            self.command_pub.put(grip_force_n=decision.grip_force_n, position_m=decision.position_m,
                                 mode=decision.mode)
        if rx_s is not None and decision.stepped:
            self.latency_s.append(time.monotonic() - rx_s)
        if decision.release_event:
            self.release_pub.put(grip_force_n=decision.grip_force_n, pull_force_n=decision.pull_force_n,
                                 controller=self.config.controller)
            log.info("object released", extra=kv(pull_force_n=round(decision.pull_force_n, 3)))
        key = (decision.mode, decision.sensors_fresh, decision.released, decision.reason)
        if key != self.last_key or now_s - self.last_state_s >= self.state_period_s:
            if key != self.last_key and decision.mode == "hold":
                # One line per kind of reason per period ("stale for 0.053 s" and "0.061 s"
                # are one kind); the state message carries every change. Sensors not heard from
                # yet (start-up) are no warning; sensors that went stale are.
                starting = all(part.endswith("never received") for part in decision.reason.split("; "))
                self.hold_log.log(logging.INFO if starting else logging.WARNING,
                                  re.sub(r"[0-9.]+", "#", decision.reason), "holding the grip", reason=decision.reason)
            self.state_pub.put(mode=decision.mode, grip_force_n=decision.grip_force_n,
                               controller=self.config.controller, sensors_fresh=decision.sensors_fresh,
                               released=decision.released, reason=decision.reason)
            self.last_state_s, self.last_key = now_s, key

    def latency_summary(self) -> dict:
        """Median and p99 of wrench receive → command published, µs (this process only)."""
        if not self.latency_s:
            return {"latency_samples": 0}
        a = np.asarray(self.latency_s) * 1e6
        return {"latency_samples": int(a.size), "latency_median_us": round(float(np.median(a)), 1),
                "latency_p99_us": round(float(np.percentile(a, 99)), 1)}


class SupervisorWord:
    """What of the supervisor's state the gripper acts on: (episode, grip request)."""

    def __init__(self) -> None:
        self.last: tuple[int, str] | None = None

    def changed(self, msg) -> bool:
        """Whether `msg` (a `supervisor/state`) differs from the last one seen in what the
        gripper acts on (Zenoh's thread: the subscription's callbacks run one at a time)."""
        word = (msg.episode_id, msg.grip_request)
        if word == self.last:
            return False
        self.last = word
        return True


def _offer_queued(gripper_io: _GripperIO, wrench_sub, motion_sub) -> None:
    """Main-thread path (`step_in_callback = false`): hand the queued samples to the core."""
    with gripper_io.lock:
        for rx in wrench_sub.drain():
            f = rx.msg.force_n
            gripper_io.core.offer_wrench(WrenchReading(force_x_n=f[0], force_y_n=f[1], rx_s=rx.rx_monotonic))
        for rx in motion_sub.drain():
            m = rx.msg
            gripper_io.core.offer_motion(MotionReading(accel_y_m_s2=m.accel_y_m_s2,
                                                       slip_velocity_x_m_s=m.velocity_m_s[0],
                                                       slip_velocity_y_m_s=m.velocity_m_s[1],
                                                       surface_valid=m.surface_valid, rx_s=rx.rx_monotonic))
        gripper_io.core.note_rejected("wrist_wrench", wrench_sub.stats.rejected)
        gripper_io.core.note_rejected("object_motion", motion_sub.stats.rejected)


def supervisor_runs(profile: Profile) -> bool:
    """Whether this run has a supervisor: the launcher's list of clock participants when it set
    one, else the profile's (enabled) supervisor."""
    started = os.environ.get(CLOCK_ENV + "_PARTICIPANTS")
    if started is not None:
        return "supervisor" in started.split(",")
    spec = profile.service("supervisor")
    return spec is not None and spec.enabled


def _next_sensor_step_s(now_s: float) -> float:
    """Simulation clock: the next step after `now_s` (s) at which a wrench sample sent at the
    bridge's tick has arrived (the sensor's grid, shifted by a participant's phase). The
    gripper steps only there (and at event steps): as on the wall clock, where a wrench sample
    wakes it, and with times on a fixed grid, so that a float sum a hair short of a period
    never shifts a step by a nanosecond."""
    return first_grid_time_s(now_s + 1e-6, 1.0 / topics.WRIST_WRENCH.nominal_rate_hz, PARTICIPANT_PHASE_S)


def run_gripper(profile: Profile, config: GripperConfig, core: GripperCore | None = None) -> int:
    """Run the gripper service until SIGINT/SIGTERM. Returns the exit code."""
    core = core or GripperCore(config)
    with ServiceNode(SERVICE_NAME, profile) as node:
        gripper_io = _GripperIO(node, config, core)
        # A supervisor state wakes the loop only when it says something new to the gripper
        # (the episode or the grip request); the others wait for the next tick.
        supervisor_sub = node.subscribe(topics.SUPERVISOR_STATE, queue_size=16, wake_if=SupervisorWord().changed)
        session = node.session
        subscribers, queued = [], None
        clock = node.clock
        if config.step_in_callback and not clock.is_sim:  # the simulation clock steps in the main thread
            subscribers = [
                session.declare_subscriber(topics.WRIST_WRENCH.key(profile.prefix), gripper_io.on_wrench),
                session.declare_subscriber(topics.OBJECT_MOTION.key(profile.prefix), gripper_io.on_motion),
            ]
        else:  # one thread hop more: decode in Zenoh's thread, step in the main thread
            # A wrench sample wakes a step; the object motion is read at that step.
            queued = (node.subscribe(topics.WRIST_WRENCH), node.subscribe(topics.OBJECT_MOTION, wake=False))
        episode_id: int | None = None
        # Simulation clock: the supervisor's first state is at its first step, 1 ms in; until
        # then the core's default request (``transfer``, for a gripper run alone) would start the
        # controller on an empty gripper. Every run waits for that word the same way.
        heard_supervisor = not (clock.is_sim and supervisor_runs(profile))
        log.info("gripper running", extra=kv(controller=config.controller, rate_hz=config.rate_hz,
                                             wrench_timeout_s=config.wrench_timeout_s,
                                             step_in_callback=config.step_in_callback))
        try:
            while not node.should_stop:
                with gripper_io.lock:
                    now_s = clock.now_s()
                    # Simulation clock: the sensor's grid, a phase after each wrench sample.
                    wait_s = _next_sensor_step_s(now_s) - now_s if clock.is_sim else core.next_due_s(now_s)
                node.wait(min(wait_s, _MAX_WAIT_S))
                if queued is not None:
                    _offer_queued(gripper_io, *queued)
                for rx in supervisor_sub.drain():
                    with gripper_io.lock:
                        if (config.rearm_on_new_episode and episode_id is not None
                                and rx.msg.episode_id != episode_id):
                            log.info("new episode: re-arming", extra=kv(episode_id=rx.msg.episode_id))
                            core.rearm()
                        if rx.msg.grip_request != core.request:
                            log.info("grip request", extra=kv(request=rx.msg.grip_request, phase=rx.msg.phase))
                            core.set_request(rx.msg.grip_request)
                    episode_id = rx.msg.episode_id
                    heard_supervisor = True
                if queued is not None:  # at rest a wrench sample changes nothing: it waits, read at the tick
                    queued[0].wakes_loop = core.releasing
                if node.should_stop:
                    break
                if not heard_supervisor:
                    continue
                with gripper_io.lock:
                    now_s = clock.now_s()
                    if core.due(now_s):
                        rx_s = core.wrench_rx_s if core.has_new_wrench and not clock.is_sim else None
                        gripper_io.publish(core.tick(now_s), now_s, rx_s)
        finally:
            for sub in subscribers:
                try:
                    sub.undeclare()
                except Exception:  # noqa: BLE001 - best-effort close: the session may already be closing
                    pass
        log.info("gripper stopped", extra=kv(steps=core.steps, holds=core.holds, released=core.released,
                                             commands_sent=gripper_io.command_gate.sent,
                                             unchanged_commands_not_sent=gripper_io.command_gate.skipped,
                                             **gripper_io.latency_summary()))
    return 0
