"""`FrankaBackend`: the bridge's `Backend` for a Franka Panda / FR3 through `franky-control`.

franky runs libfranka's 1 kHz loop on its own real-time thread; this backend gives it one
motion per bridge tick (100 Hz):

- **following**: a ``JointVelocityMotion`` of feed-forward + gain × (target − measured)
  (`core.velocity_command`), clipped to the joint velocity limits; franky's trajectory
  generator (Ruckig) shapes it within the robot's velocity, acceleration and jerk limits
  scaled by ``relative_dynamics_factor``. Each command is held ``robot_command_timeout_s``
  (50 ms) on the robot: if the bridge stalls or dies, the robot brakes by itself;
- **hold** (the bridge's 0.2 s command time-out, a refused command): a
  ``JointVelocityStopMotion`` at the same factor; at rest the robot holds its position;
- **protective stop** (`brake`, on `motion/stop`): a ``JointVelocityStopMotion`` at the
  robot's full limits, at once (the bridge does not ramp it down itself);
- **the Hand**: the stack's grip force becomes grasp / open actions (`core.GripPlanner`) on
  a worker thread (`gripper.HandWorker`);
- **faults**: the robot's clock not advancing for ``state_lost_timeout_s`` or a libfranka
  ``NetworkException`` → `FrankaLostError`; a reflex, a limit or any ``ControlException``
  → `FrankaControlError` naming the robot's error flags. Either ends the bridge (exit 1),
  and the supervisor reports the bridge lost and stops the stack;
- **dry run**: connects and reads the robot (and the Hand's width), sends no motion and no
  Hand action; each motion that would be sent is described on the dry-run sink.

All franky calls on the robot are made from the bridge's thread.
"""

from __future__ import annotations

import gc
import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from services.bridge.backend import JointReading, PublishFn
from services.bridge.franka import core
from services.bridge.franka.config import FrankaConfig, parse_franka_config
from services.bridge.franka.errors import FrankaControlError, FrankaLostError, FrankaNotReadyError
from services.bridge.franka.gripper import HandWorker
from services.runtime import RateLimitedLog, kv

log = logging.getLogger(__name__)

DrySink = Callable[[str], None]
#: The robot modes in which it can move under FCI.
MOVABLE_MODES = ("Idle", "Move")


def _log_sink(line: str) -> None:
    log.info("dry run: %s", line)


class FrankaBackend:
    """A Franka arm and its Hand (see the module docstring).

    Args:
        config: ``[services.bridge.config.franka]`` (a table or a `FrankaConfig`).
        dry_run: never move the robot or the Hand; describe the motions on `dry_run_sink`.
        dry_run_sink: receives one line per motion that would be sent (default: the log).
    """

    name = "franka"

    def __init__(self, config: FrankaConfig | dict[str, Any] | None = None, *, dry_run: bool = False,
                 dry_run_sink: DrySink | None = None) -> None:
        import franky  # imported here: only the Franka bridge needs libfranka

        self._franky = franky
        self.config = cfg = parse_franka_config(config if config is not None else {})
        self.dry_run = dry_run
        self._sink = dry_run_sink or _log_sink
        self.joint_names = cfg.names()
        self.limits = cfg.limits()
        #: The bridge's command gate refuses a target farther than this from the arm, rad.
        self.max_step_rad = cfg.max_step_rad
        self._velocity_limit = self.limits.velocity_rad_s * cfg.relative_dynamics_factor
        self._hold_ms = max(1, round(cfg.robot_command_timeout_s * 1e3))
        self._clock = core.StateClock(cfg.state_lost_timeout_s)
        self._grip = core.GripPlanner(cfg.gripper_max_force_n, cfg.gripper_min_force_n,
                                      cfg.gripper_deadband_n, cfg.gripper_min_interval_s)
        self._warn = RateLimitedLog(log, 1.0)
        self._error_names = [n for n in dir(franky.Errors) if not n.startswith("_")]
        self._moving = False  # a velocity motion of ours may be running on the robot
        self._braked = False
        self.sent = {"velocity": 0, "stop": 0, "brake": 0}
        self.hand: HandWorker | None = None
        self.robot = self._connect()
        self._state: Any = None
        self._reading = JointReading(np.zeros(7), np.zeros(7), np.zeros(7))
        try:
            self._poll()
            if cfg.gripper:
                self.hand = HandWorker(franky.Gripper(cfg.host), cfg.gripper_speed_m_s)
        except franky.Exception as exc:
            self.close()
            raise FrankaNotReadyError(f"the Franka at {cfg.host} answered, then failed: {exc}") from None
        except BaseException:
            self.close()
            raise
        log.info("franka ready", extra=kv(host=cfg.host, model=cfg.model, dry_run=dry_run,
                                          mode=self._mode(), gripper=self.hand is not None))

    # ------------------------------------------------------------------ start-up
    def _connect(self) -> Any:
        franky, cfg = self._franky, self.config
        try:
            robot = self._open(franky.RealtimeConfig.Enforce if cfg.realtime == "enforce"
                               else franky.RealtimeConfig.Ignore)
        except franky.RealtimeException as exc:
            raise FrankaNotReadyError(f"{exc}: run on a PREEMPT_RT kernel (docs/franka.md), or set "
                                      "realtime = \"ignore\" for a simulator") from None
        except franky.IncompatibleVersionException as exc:
            raise FrankaNotReadyError(f"{exc}: the robot's system version does not match franky's libfranka "
                                      "(docs/franka.md#versions)") from None
        except franky.Exception as exc:
            raise FrankaNotReadyError(f"cannot reach the Franka at {cfg.host} within {cfg.connect_timeout_s:.0f} s: "
                                      f"{exc} (is FCI enabled in Desk, the brakes open, and this PC on the "
                                      "robot's network? docs/franka.md)") from None
        return self._check_ready(robot)

    def _open(self, realtime: Any) -> Any:
        """Connect, retrying for ``connect_timeout_s`` (a simulator or Control box starting up)."""
        franky, cfg = self._franky, self.config
        deadline = time.monotonic() + cfg.connect_timeout_s
        while True:
            try:
                return franky.Robot(cfg.host, relative_dynamics_factor=cfg.relative_dynamics_factor,
                                    default_torque_threshold=cfg.torque_threshold_nm,
                                    default_force_threshold=cfg.force_threshold_n, realtime_config=realtime)
            except franky.NetworkException:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)

    def _check_ready(self, robot: Any) -> Any:
        """`robot` if it can move (a dry run only says when not), after recovery if asked."""
        cfg = self.config
        state = robot.state
        errors = core.active_flags(state.current_errors, self._error_names)
        if errors and cfg.recover_on_start and not self.dry_run:
            log.warning("recovering the robot from errors", extra=kv(errors=",".join(errors)))
            robot.recover_from_errors()
            state = robot.state
            errors = core.active_flags(state.current_errors, self._error_names)
        mode = state.robot_mode.name
        if errors or mode not in MOVABLE_MODES:
            problem = f"robot mode {mode}" + (f", {core.describe_errors(errors)}" if errors else "")
            if not self.dry_run:
                raise FrankaNotReadyError(f"refusing to start: {problem} (release the stop, recover in Desk "
                                          "or run with --recover)")
            self._sink(f"robot not ready ({problem}); a real run would refuse to start")
        return robot

    # ------------------------------------------------------------------ reading
    def _mode(self) -> str:
        return self._state.robot_mode.name if self._state is not None else "unknown"

    def _poll(self) -> None:
        """Read the robot's state; raise on a lost robot or a motion the robot aborted."""
        franky = self._franky
        try:
            state = self.robot.state
            if self._moving:
                self.robot.poll_motion()  # raises what aborted our motion (a ControlException)
        except franky.NetworkException as exc:
            raise FrankaLostError(f"lost the Franka at {self.config.host}: {exc} (network, power or the "
                                  "robot's own stop: check the arm and the FCI link)") from None
        except franky.ControlException as exc:
            raise FrankaControlError(self._control_message(str(exc))) from None
        except (franky.Exception, RuntimeError) as exc:  # franky raises RuntimeError for a dead link too
            raise FrankaLostError(f"the Franka at {self.config.host} failed: {exc}") from None
        now = time.monotonic()
        self._clock.update(int(state.time.to_msec()), now)
        self._state = state
        self._reading = JointReading(np.array(state.q, float), np.array(state.dq, float), np.array(state.tau_J, float))
        if state.robot_mode.name == "Reflex" or core.active_flags(state.current_errors, self._error_names):
            raise FrankaControlError(self._control_message(f"robot mode {state.robot_mode.name}"))

    def _control_message(self, what: str) -> str:
        flags: list[str] = []
        if self._state is not None:
            flags = (core.active_flags(self._state.current_errors, self._error_names)
                     or core.active_flags(self._state.last_motion_errors, self._error_names))
        detail = core.describe_errors(flags) or "no error flag reported"
        return f"the Franka aborted the motion ({what}): {detail}; recover in Desk or with --recover"

    # ------------------------------------------------------------------ Backend protocol
    def step(self, dt_s: float) -> None:
        """Poll the robot (raises `FrankaLostError` / `FrankaControlError`)."""
        self._poll()
        silent = self._clock.silent_s(time.monotonic())
        if silent > self.config.state_lost_timeout_s:
            raise FrankaLostError(f"the Franka's state has not advanced for {silent:.2f} s "
                                  f"(limit {self.config.state_lost_timeout_s:.2f} s): check the robot and its network")
        if self.hand is not None and self.hand.error is not None:
            raise FrankaLostError(f"the Franka Hand failed: {self.hand.error}")

    def catch_up(self, gap_s: float) -> None:
        """Nothing to simulate: the robot lived through the stall (and braked by itself
        ``robot_command_timeout_s`` after the last command)."""
        return None

    def command(self, target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None = None) -> None:
        """Stream toward `target_rad` (checked by the bridge's gate) at `feedforward_rad_s`."""
        self._braked = False
        velocity = core.velocity_command(target_rad, feedforward_rad_s, self._reading.position_rad,
                                         self.config.position_gain_per_s, self._velocity_limit)
        if self.dry_run:
            self._sink(core.describe_velocity(self.joint_names, velocity, self._hold_ms / 1e3))
            return
        self._move(self._franky.JointVelocityMotion(velocity, duration=self._franky.Duration(self._hold_ms)))
        self._moving = True
        self.sent["velocity"] += 1

    def hold(self) -> None:
        """Bring the arm to rest (once); at rest the robot holds its position."""
        self._stop("stop", self.config.relative_dynamics_factor)

    def brake(self) -> None:
        """A protective stop: decelerate at the robot's full limits at once (once)."""
        if not self._braked:
            self._braked = True
            self._stop("brake", 1.0)

    def _stop(self, kind: str, factor: float) -> None:
        if not self._moving:
            return
        self._moving = False
        if self.dry_run:
            self._sink(f"JointVelocityStopMotion ({kind}, dynamics factor {factor:.2f})")
            return
        self._move(self._franky.JointVelocityStopMotion(relative_dynamics_factor=factor))
        self.sent[kind] += 1

    def _move(self, motion: Any) -> None:
        franky = self._franky
        try:
            self.robot.move(motion, asynchronous=True)
        except franky.NetworkException as exc:
            raise FrankaLostError(f"lost the Franka at {self.config.host}: {exc}") from None
        except franky.ControlException as exc:
            raise FrankaControlError(self._control_message(str(exc))) from None

    def read(self) -> JointReading:
        r = self._reading
        return JointReading(r.position_rad.copy(), r.velocity_rad_s.copy(), r.effort_nm.copy())

    def publish_extras(self, publish: PublishFn) -> None:
        """Nothing beyond the joint state yet (the external wrench estimate: docs/franka.md)."""
        return None

    def gripper_command(self, grip_force_n: float) -> None:
        if self.hand is None:
            return
        action = self._grip.plan(grip_force_n, time.monotonic())
        if action is None:
            return
        if self.dry_run:
            self._sink(f"Hand {action.kind}" + (f" force {action.force_n:.1f} N" if action.kind == "grasp" else ""))
            return
        self.hand.request(action)

    @property
    def enabled(self) -> bool:
        """The robot is in a mode where it can move (Idle or Move, no error)."""
        return self._mode() in MOVABLE_MODES

    def new_episode(self) -> None:
        """A new episode changes nothing on the robot."""
        return None

    def episode_running(self, running: bool) -> None:
        """Nothing on the robot sleeps between episodes."""
        return None

    def close(self) -> None:
        """Bring the arm to rest if one of our motions runs, stop the Hand's thread."""
        try:
            if self._moving and not self.dry_run and self.robot is not None:
                self._moving = False
                self.robot.move(self._franky.JointVelocityStopMotion(), asynchronous=True)
                self.robot.join_motion(1.0)
        except Exception as exc:  # noqa: BLE001 - shutdown path: the robot may already be gone
            log.warning("could not stop the Franka cleanly: %s", exc)
        if self.hand is not None:
            self.hand.close()
        self.robot = None  # free libfranka's objects now, not during the interpreter's teardown
        gc.collect()
        log.info("franka backend closed", extra=kv(**{f"sent_{k}": v for k, v in self.sent.items()},
                                                   grip_clipped=self._grip.clipped))
