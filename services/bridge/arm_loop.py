"""What the bridge does at each tick of its loop, apart from the bus.

One tick: live through a stall under the old command (`Backend.catch_up`), read the arm,
take the stops and goals in arrival order (`StopBrake`), reset the scene on a new supervisor
episode (and tell the backend whether an episode runs: a simulated scene's still physics
sleeps outside one, `Backend.episode_running`), take the joint commands through the
`CommandGate`, pass the newest grip command on, then brake, hold or servo, step the backend
and return the joint state to publish. The backend's extra messages go out through
`ArmLoop.publish_extras`, `sim/truth` only when it changed by more than 1 nm (`settled_key`)
or every `TRUTH_REPEAT_S` at rest.

The caller passes the local monotonic time (s) and the queues of what arrived since the last
tick (`Inbox`, drained here in the order the bridge always read them).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from bus_schema import topics
from bus_schema.messages import PHASES_OUTSIDE_EPISODE
from services.bridge.backend import Backend, PublishFn
from services.bridge.config import BridgeConfig
from services.bridge.core import CommandGate, StopBrake
from services.bridge.supervisor_loss import SupervisorLoss
from services.runtime import RateLimitedLog, kv
from services.runtime.pubsub import Received
from services.runtime.repeat import RepeatGate, settled_key

log = logging.getLogger(__name__)

#: A tick later than this many periods is a stall the backend catches up on (`Backend.catch_up`).
STALL_PERIODS = 2.0
#: `sim/truth` goes out on every tick where any of its values changed, and otherwise again
#: this often, s. The simulation's truth at rest (the object in the receiver's hand, the arm
#: still) is the same message 100 times a second, each crossing the router to the launcher and
#: the recorder (and the tracker's simulated Kinect): issue 16. Its readers take the newest
#: value, so an unchanged one need not be repeated; every change still goes out at once.
TRUTH_REPEAT_S = 0.1
#: At most one "joint command rejected" line per this many seconds.
REJECT_LOG_PERIOD_S = 1.0


class Queue(Protocol):
    """What arrived on one topic since the last drain (a `TypedSubscription`)."""

    def drain(self) -> list[Received[Any]]:
        """The messages received since the last call, oldest first."""
        ...


@dataclass(frozen=True)
class Inbox:
    """The bridge's inputs, drained once per tick.

    Attributes:
        stops: `motion/stop`.
        goals: `motion/goal` (a goal sent after a stop ends it).
        supervisor: `supervisor/state` (a new episode resets the scene).
        commands: `robot/joint_command`.
        grips: `gripper/command`.
    """

    stops: Queue
    goals: Queue
    supervisor: Queue
    commands: Queue
    grips: Queue


class ArmLoop:
    """The bridge's state across ticks: command gate, stop brake, episode, truth repeats.

    Args:
        backend: the robot (`services.bridge.backend`).
        config: the bridge's config (rate, command time-out, limit tolerance, braking).
        start_s: local monotonic time the loop starts at, s (the first tick's dt counts from it).
    """

    def __init__(self, backend: Backend, config: BridgeConfig, start_s: float) -> None:
        self.backend = backend
        self.period_s = 1.0 / config.rate_hz
        self.gate = CommandGate(backend.joint_names, backend.limits, config.command_timeout_s,
                                config.limit_tolerance_rad, getattr(backend, "max_step_rad", None))
        self.brake = StopBrake(config.stop_deceleration_rad_s2)
        self.truth_gate = RepeatGate(TRUTH_REPEAT_S)
        #: The newest `motion/stop` drained so far (a newer one queued makes a tick urgent).
        self.newest_stop: Received[Any] | None = None
        self.episode_id: int | None = None
        #: The supervisor's liveliness against its episodes (`services.bridge.supervisor_loss`).
        self.supervisor_loss = SupervisorLoss()
        #: The reason of a protective stop this loop decided itself, for the caller to send on
        #: ``motion/stop`` (`take_own_stop`).
        self._own_stop: str | None = None
        self._reject_log = RateLimitedLog(log, REJECT_LOG_PERIOD_S)
        self._last_s = start_s
        self._was_holding = True
        #: What the backend was last told by `Backend.episode_running`.
        self._episode_running: bool | None = None

    def tick(self, now_s: float, inbox: Inbox) -> dict[str, Any]:
        """Run one tick at local time `now_s` (monotonic s); returns the `robot/joint_state`
        fields to publish."""
        dt_s = self._elapsed_s(now_s)
        backend = self.backend
        measured = backend.read()
        current = measured.position_rad
        self._take_stops_and_goals(inbox.stops.drain(), inbox.goals, measured.velocity_rad_s)
        tokens = self.supervisor_loss.take_tokens()  # before the states: see `SupervisorLoss`
        for rx in inbox.supervisor.drain():
            self._take_supervisor(rx.msg.episode_id)
            self.supervisor_loss.state(rx.msg.phase, rx.msg.episode_id)
        self._check_supervisor(tokens, measured.velocity_rad_s)
        # No supervisor heard: as in an episode (a simulated world never sleeps then).
        running = self.supervisor_loss.phase not in PHASES_OUTSIDE_EPISODE
        if running != self._episode_running:
            backend.episode_running(running)
            self._episode_running = running
        for rx in inbox.commands.drain():
            self._take_command(rx, current)
        grips = inbox.grips.drain()
        if grips:
            backend.gripper_command(grips[-1].msg.grip_force_n)
        holding = self._drive(now_s, dt_s, current)
        backend.step(dt_s)
        reading = backend.read()
        return {
            "names": list(backend.joint_names),
            "position_rad": reading.position_rad.tolist(),
            "velocity_rad_s": reading.velocity_rad_s.tolist(),
            "effort_nm": reading.effort_nm.tolist(),
            "holding": holding,
            "backend": backend.name,
            "enabled": bool(backend.enabled),
        }

    def publish_extras(self, publish: PublishFn, now_s: float) -> None:
        """The backend's extra messages through `publish`; `sim/truth` only when due at `now_s`
        (monotonic s)."""
        def gated(suffix: str, fields: dict[str, Any]) -> None:
            if suffix == topics.SIM_TRUTH.suffix and not self.truth_gate.due(settled_key(fields.values()), now_s):
                return
            publish(suffix, fields)

        self.backend.publish_extras(gated)

    def _elapsed_s(self, now_s: float) -> float:
        """The dt of this tick, s. After a stall the robot did not wait for the loop: the
        backend (and the brake's ramp) live through the gap under the old command before this
        tick's stops and commands act, and the tick itself steps one period."""
        dt_s, self._last_s = now_s - self._last_s, now_s
        period = self.period_s
        if dt_s > STALL_PERIODS * period:
            self.backend.catch_up(dt_s - period)
            if self.brake.active:
                self.brake.step(dt_s - period)  # the brake's ramp went on too
            dt_s = period
        return dt_s

    def _take_stops_and_goals(self, new_stops: list[Received[Any]], goals: Queue,
                              velocity_rad_s: np.ndarray) -> None:
        """Stops and goals in arrival order; a goal ends a stop only if sent after it (by the
        stamps when both come from one source, `StopBrake.goal_after_stop`)."""
        if new_stops:
            self.newest_stop = new_stops[-1]
        events = sorted([(rx.rx_monotonic, 0, rx) for rx in new_stops]
                        + [(rx.rx_monotonic, 1, rx) for rx in goals.drain()], key=lambda e: (e[0], e[1]))
        brake = self.brake
        for _t, kind, rx in events:
            msg = rx.msg
            if kind == 1:
                brake.goal_after_stop(msg.goal_id, msg.source, msg.stamp_ns)
                continue
            if not brake.active:  # a release stop is the normal handover; a protective one is not
                log.log(logging.WARNING if msg.protective else logging.INFO, "stop: braking",
                        extra=kv(reason=msg.reason, protective=msg.protective, source=msg.source))
            brake.engage(msg.reason, velocity_rad_s, msg.protective, msg.source, msg.stamp_ns)

    def _take_supervisor(self, episode_id: int) -> None:
        """A supervisor state of `episode_id`: a new episode ends a latched protective stop and
        resets a simulated scene."""
        if self.episode_id is not None and episode_id != self.episode_id:
            self.brake.new_episode()
            log.info("new episode", extra=kv(episode_id=episode_id, backend=self.backend.name))
            self.backend.new_episode()
        self.episode_id = episode_id

    def _check_supervisor(self, tokens: list[bool], velocity_rad_s: np.ndarray) -> None:
        """Brake, protectively, when the supervisor's token went (one of `tokens`) during one of
        its episodes."""
        reason = self.supervisor_loss.due(tokens)
        if reason is None:
            return
        log.warning("supervisor lost: braking", extra=kv(reason=reason, already_braking=self.brake.active))
        self.brake.engage(reason, velocity_rad_s, protective=True, source="bridge")
        self._own_stop = reason

    def take_own_stop(self) -> str | None:
        """The reason of the protective stop this loop decided since the last call (to send on
        ``motion/stop``), or None."""
        reason, self._own_stop = self._own_stop, None
        return reason

    def _take_command(self, rx: Received[Any], current_rad: np.ndarray) -> None:
        """A joint command, unless the brake ignores its goal; a rejected one is logged
        (rate-limited) and the arm holds."""
        msg = rx.msg
        if not self.brake.admit(msg.goal_id):
            return
        reason = self.gate.offer(msg.names, msg.position_rad, rx.rx_monotonic, current_rad, msg.velocity_rad_s)
        if reason is not None:
            self._reject_log.warning("rejected", f"joint command rejected, holding: {reason}",
                                     source=msg.source, seq=msg.seq)

    def _drive(self, now_s: float, dt_s: float, current_rad: np.ndarray) -> bool:
        """Brake, hold or servo the arm for this tick; returns whether it holds."""
        backend, brake = self.backend, self.brake
        decision = self.gate.decide(now_s)
        if brake.active and hasattr(backend, "brake"):
            backend.brake()  # a robot that brakes within its own limits (the Franka): at once
            holding = True
        elif brake.active:
            velocity = brake.step(dt_s)
            if brake.at_rest:
                backend.hold()
            else:
                backend.command(current_rad, velocity)
            holding = True
        else:
            if decision.holding:
                backend.hold()
                if not self._was_holding:
                    log.info("arm holding", extra=kv(reason=decision.reason))
            else:
                assert decision.target_rad is not None  # a decision that does not hold has a target
                backend.command(decision.target_rad, decision.feedforward_rad_s)
            holding = decision.holding
        self._was_holding = holding
        return holding
