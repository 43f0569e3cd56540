"""`BaxterBackend`: the bridge's `Backend` for a real Baxter, through ROS 1 bytes on Zenoh.

The robot side runs ROS 1 (Baxter's own ``roscore`` and nodes, the F/T and optical sensor
nodes) and the Zenoh ROS 1 bridge, which carries each topic's raw ROS 1 serialisation on a
Zenoh key (`keys.topic_key`). This backend opens its own Zenoh client session on the stack's
router and

- subscribes ``/robot/joint_states`` (arm reading), ``/robot/state`` (enabled, e-stop), the
  wrist wrench and the optical sensor;
- publishes ``/robot/limb/right/joint_command`` (position mode, every bridge tick, 100 Hz),
  the gripper's ``EndEffectorCommand`` (throttled to the gripper's 20 Hz loop), the limb's
  command time-out at start, and ``/robot/set_super_enable`` when configured to.

Safety (on top of the bridge's `CommandGate`, which validates commands and holds after its
200 ms time-out):

- refuses to start unless joint states arrive and the robot reports enabled (or, with
  ``enable_on_start``, becomes enabled when asked) within ``startup_timeout_s``;
- sets the robot's own joint-command time-out (``robot_command_timeout_s``): if the bridge
  stalls or dies, Baxter stops following within that time by itself;
- clamps every command inside the joint limits minus ``limit_margin_rad`` and within
  ``max_step_rad`` of the measured position;
- sends nothing while the joint state is stale (``state_timeout_s``); stops the bridge
  (`BaxterLostError`) when joint states stop for ``state_lost_timeout_s`` or the robot is
  disabled or e-stopped while running;
- ``dry_run``: nothing is ever sent to the robot; each message that would be sent is
  described on the dry-run sink (the CLI prints it) instead.

Decoding happens in the Zenoh callbacks (typed, bounded, never raises into Zenoh); the bridge
thread reads the latest values.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
import zenoh

from handover_model import robots
from handover_model.robots import BAXTER, arm_model
from handover_model.robots.baxter import RIGHT_ARM_JOINTS
from services.bridge.backend import JointReading, PublishFn
from services.bridge.baxter import core
from services.bridge.baxter.config import BaxterConfig, parse_baxter_config
from services.bridge.baxter.errors import BaxterConfigError, BaxterLostError, BaxterNotReadyError
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import (
    AssemblyState,
    Bool,
    EndEffectorCommand,
    Float64,
    JointCommand,
    JointState,
    OpticalMotion,
    WrenchStamped,
)
from services.bridge.baxter.ros1 import Ros1DecodeError, Ros1Message
from services.runtime import Profile, RateLimitedLog, kv
from services.runtime.node import open_session

log = logging.getLogger(__name__)

DrySink = Callable[[str], None]


def _log_sink(line: str) -> None:
    log.info("dry run: %s", line)


class _Latest:
    """Latest decoded message of one key, its local receive time and counters."""

    def __init__(self, cls: type[Ros1Message], key: str, keep: int = 0) -> None:
        self.cls = cls
        self.key = key
        self.latest: Any = None
        self.rx_s = -np.inf
        self.received = 0
        self.rejected = 0
        self.queue: deque[Any] | None = deque(maxlen=keep) if keep else None
        self._bad_log = RateLimitedLog(log, 1.0)

    def on_sample(self, sample: zenoh.Sample) -> None:  # Zenoh thread: decode, store, return
        try:
            msg = self.cls.from_bytes(sample.payload.to_bytes())
        except Ros1DecodeError as exc:
            self.rejected += 1
            self._bad_log.warning(self.key, f"dropped undecodable {self.cls.TYPE} on {self.key}: {exc}")
            return
        except Exception as exc:  # noqa: BLE001 - a Zenoh callback: nothing may escape into Zenoh's thread
            self.rejected += 1
            self._bad_log.warning(self.key, f"dropped payload on {self.key}: {exc!r}")
            return
        self.received += 1
        if self.queue is not None:
            self.queue.append(msg)
        self.latest = msg
        self.rx_s = time.monotonic()

    def drain(self) -> list[Any]:
        out = []
        while self.queue:
            try:
                out.append(self.queue.popleft())
            except IndexError:
                break
        return out


class BaxterBackend:
    """Baxter's right arm, gripper and wrist sensors (see module docstring).

    Args:
        profile: the deploy profile (its router is where the Zenoh ROS 1 bridge connects).
        config: ``[services.bridge.config.baxter]`` (a table or a `BaxterConfig`).
        dry_run: never send anything to the robot; describe it on `dry_run_sink`.
        dry_run_sink: receives one line per message that would be sent (default: the log).
        user: the bus user of this session (the bridge's credentials in a multi-host profile).
        session: an open Zenoh session to use instead of opening one (not closed by us).
    """

    name = "baxter"

    def __init__(self, profile: Profile, config: BaxterConfig | dict[str, Any] | None = None, *,
                 dry_run: bool = False, dry_run_sink: DrySink | None = None, user: str = "bridge",
                 session: zenoh.Session | None = None) -> None:
        arm = robots.active()
        if arm.name != BAXTER.name:
            raise BaxterConfigError(f"the Baxter backend drives a Baxter, but the profile's arm is {arm.name!r}: "
                                    "set [robot] model = \"baxter\" (or drop --robot)")
        self.config = cfg = parse_baxter_config(config if config is not None else {})
        self.dry_run = dry_run
        self._sink = dry_run_sink or _log_sink
        self.joint_names = RIGHT_ARM_JOINTS
        self.limits = arm_model(BAXTER).limits
        self._warn = RateLimitedLog(log, 1.0)
        self._lock = threading.Lock()

        def key(topic: str, cls: type[Ros1Message]) -> str:
            return topic_key(topic, cls.TYPE, cfg.key_format, cfg.key_namespace)

        t = cfg.topics
        self.keys = {
            "joint_states": key(t.joint_states, JointState),
            "robot_state": key(t.robot_state, AssemblyState),
            "wrist_wrench": key(t.wrist_wrench, WrenchStamped),
            "optical_motion": key(t.optical_motion, OpticalMotion),
            "joint_command": key(t.joint_command, JointCommand),
            "joint_command_timeout": key(t.joint_command_timeout, Float64),
            "enable": key(t.enable, Bool),
            "gripper_command": key(t.gripper_command, EndEffectorCommand),
        }
        self._joint_states = _Latest(JointState, self.keys["joint_states"], keep=0)
        self._robot_state = _Latest(AssemblyState, self.keys["robot_state"])
        self._wrench = _Latest(WrenchStamped, self.keys["wrist_wrench"], keep=2000)
        self._optical = _Latest(OpticalMotion, self.keys["optical_motion"], keep=2000)
        # Arm readings: only joint-state messages that carry the whole arm.
        self._arm: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._arm_rx_s = -np.inf
        self._wrench_conv = core.WrenchConverter(cfg.ft_rotation, cfg.ft_tare_samples)
        self._optical_est = core.OpticalEstimator(cfg.optical_rotation, cfg.optical_counts_per_m, cfg.accel_filter_hz)
        self._grip_throttle = core.GripperThrottle(cfg.gripper_min_interval_s, cfg.gripper_deadband_percent)
        self._grip_seq = 0
        self._hold_rad: np.ndarray | None = None
        self.sent: dict[str, int] = {name: 0 for name in ("joint_command", "gripper_command", "enable",
                                                            "joint_command_timeout")}
        self.clamped = 0
        self.skipped_stale = 0

        self._own_session = session is None
        self._session = session or open_session(profile, "client", timeout_s=cfg.startup_timeout_s, user=user)
        self._subscribers: list[Any] = []
        self._publishers: dict[str, Any] = {}
        try:
            self._subscribers = [
                self._session.declare_subscriber(self.keys["joint_states"], self._on_joint_states),
                self._session.declare_subscriber(self.keys["robot_state"], self._robot_state.on_sample),
                self._session.declare_subscriber(self.keys["wrist_wrench"], self._wrench.on_sample),
                self._session.declare_subscriber(self.keys["optical_motion"], self._optical.on_sample),
            ]
            if not dry_run:
                for name in ("joint_command", "joint_command_timeout", "enable", "gripper_command"):
                    self._publishers[name] = self._session.declare_publisher(
                        self.keys[name], congestion_control=zenoh.CongestionControl.BLOCK,
                        priority=zenoh.Priority.REAL_TIME)
            self._start()
        except BaseException:
            self.close(disable=False)
            raise

    # ------------------------------------------------------------------ Zenoh callbacks
    def _on_joint_states(self, sample: zenoh.Sample) -> None:
        self._joint_states.on_sample(sample)
        msg = self._joint_states.latest
        if msg is None or self._joint_states.rx_s == self._arm_rx_s:
            return
        picked = core.select_joints(msg, self.joint_names)
        if picked is not None:
            with self._lock:
                self._arm = picked
                self._arm_rx_s = self._joint_states.rx_s

    # ------------------------------------------------------------------ start-up
    def _start(self) -> None:
        cfg = self.config
        deadline = time.monotonic() + cfg.startup_timeout_s
        while time.monotonic() < deadline and (self._arm is None or self._robot_state.latest is None):
            time.sleep(0.01)
        if self._arm is None:
            raise BaxterNotReadyError(
                f"no joint states of the right arm on {self.keys['joint_states']} within "
                f"{cfg.startup_timeout_s:.1f} s: is the robot on, and zenoh-bridge-ros1 running on the "
                "robot side and connected to this router (docs/baxter.md)?")
        if self._robot_state.latest is None:
            raise BaxterNotReadyError(
                f"no robot state on {self.keys['robot_state']} within {cfg.startup_timeout_s:.1f} s: "
                "is /robot/state bridged (docs/baxter.md)?")
        problem = core.robot_state_problem(self._robot_state.latest)
        if problem and cfg.enable_on_start and not self._robot_state.latest.stopped:
            log.info("enabling the robot", extra=kv(key=self.keys["enable"]))
            self._send("enable", Bool(True))
            if not self.dry_run:
                deadline = time.monotonic() + cfg.startup_timeout_s
                while time.monotonic() < deadline and core.robot_state_problem(self._robot_state.latest):
                    time.sleep(0.01)
                problem = core.robot_state_problem(self._robot_state.latest)
        if problem:
            if not self.dry_run:
                raise BaxterNotReadyError(f"refusing to start: {problem}")
            self._sink(f"robot not ready ({problem}); a real run would refuse to start")
        self._send("joint_command_timeout", Float64(cfg.robot_command_timeout_s))
        self._hold_rad = self._arm[0].copy()
        log.info("baxter ready", extra=kv(enabled=not problem, dry_run=self.dry_run,
                                          joint_states=self.keys["joint_states"]))

    # ------------------------------------------------------------------ sending
    def _send(self, name: str, msg: Ros1Message) -> None:
        payload = msg.to_bytes()
        if self.dry_run:
            self._sink(core.describe(self.keys[name], msg, payload))
        else:
            self._publishers[name].put(payload)
        self.sent[name] = self.sent.get(name, 0) + 1

    def _arm_reading(self) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], float]:
        with self._lock:
            assert self._arm is not None  # _start guarantees a reading
            return self._arm, self._arm_rx_s

    def _can_command(self) -> bool:
        (position, _, _), rx_s = self._arm_reading()
        age_s = time.monotonic() - rx_s
        if age_s > self.config.state_timeout_s:
            self.skipped_stale += 1
            self._warn.warning("stale", f"joint state {age_s * 1e3:.0f} ms old: no command sent",
                               skipped=self.skipped_stale)
            return False
        return True

    def _send_position(self, target_rad: np.ndarray) -> None:
        (measured, _, _), _ = self._arm_reading()
        result = core.clamp_command(target_rad, measured, self.limits.lower_rad, self.limits.upper_rad,
                                    self.config.limit_margin_rad, self.config.max_step_rad)
        if result.limited or result.stepped:
            self.clamped += 1
            self._warn.warning("clamped", "joint command clamped",
                               limits=[self.joint_names[i] for i in result.limited],
                               step=[self.joint_names[i] for i in result.stepped])
        self._send("joint_command", JointCommand(mode=JointCommand.POSITION_MODE,
                                                 command=tuple(float(v) for v in result.target_rad),
                                                 names=self.joint_names))

    # ------------------------------------------------------------------ Backend protocol
    def step(self, dt_s: float) -> None:
        """Check the robot: joint states still coming, still enabled (raises otherwise)."""
        _, rx_s = self._arm_reading()
        age_s = time.monotonic() - rx_s
        if age_s > self.config.state_lost_timeout_s:
            raise BaxterLostError(
                f"no joint state from the robot for {age_s:.2f} s (limit {self.config.state_lost_timeout_s:.2f} s): "
                "check the robot, its network and zenoh-bridge-ros1")
        problem = core.robot_state_problem(self._robot_state.latest)
        if problem and not self.dry_run:
            raise BaxterLostError(f"robot no longer commandable: {problem}")

    def catch_up(self, gap_s: float) -> None:
        """Nothing to simulate: the robot lived through the stall, under its own command
        time-out (``robot_command_timeout_s``)."""
        return None

    def command(self, target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None = None) -> None:
        """Send a position command (Baxter's position mode has no velocity feed-forward)."""
        self._hold_rad = None
        if self._can_command():
            self._send_position(np.asarray(target_rad, float))

    def hold(self) -> None:
        """Keep commanding the position measured when the hold began."""
        if self._hold_rad is None:
            self._hold_rad = self._arm_reading()[0][0].copy()
        if self._can_command():
            self._send_position(self._hold_rad)

    def read(self) -> JointReading:
        (position, velocity, effort), _ = self._arm_reading()
        return JointReading(position.copy(), velocity.copy(), effort.copy())

    def publish_extras(self, publish: PublishFn) -> None:
        """Publish the wrist wrench (mean of this tick's samples) and the optical motion
        (this tick's samples combined), in the gripper frame; nothing when no new sample."""
        forces, torques = [], []
        for msg in self._wrench.drain():
            w = msg.wrench
            out = self._wrench_conv.convert((w.force.x, w.force.y, w.force.z), (w.torque.x, w.torque.y, w.torque.z))
            if out is not None:
                forces.append(out[0])
                torques.append(out[1])
        if forces:
            f = np.clip(np.mean(forces, axis=0), -1e4, 1e4)
            tq = np.clip(np.mean(torques, axis=0), -1e3, 1e3)
            publish("sensors/wrist_wrench", {"force_n": tuple(f.tolist()), "torque_nm": tuple(tq.tolist())})
        cfg = self.config
        samples = [self._optical_est.to_gripper(m.dx_counts, m.dy_counts, m.dt, m.surface_quality,
                                                cfg.optical_min_quality) for m in self._optical.drain()]
        fields = self._optical_est.combine(samples)
        if fields is not None:
            publish("sensors/object_motion", fields)

    def gripper_command(self, grip_force_n: float) -> None:
        percent = core.grip_percent(grip_force_n, self.config.gripper_force_full_scale_n)
        if self._grip_throttle.should_send(percent, time.monotonic()):
            self._grip_seq += 1
            self._send("gripper_command", core.gripper_go_command(
                grip_force_n, self.config.gripper_force_full_scale_n, self.config.gripper_id, self._grip_seq))

    @property
    def enabled(self) -> bool:
        """The robot reports enabled and not stopped."""
        return not core.robot_state_problem(self._robot_state.latest)

    def new_episode(self) -> None:
        """A new episode changes nothing on the robot."""
        return None

    def episode_running(self, running: bool) -> None:
        """Nothing on the robot sleeps between episodes."""
        return None

    def stats(self) -> dict[str, Any]:
        return {"sent": dict(self.sent), "clamped": self.clamped, "skipped_stale": self.skipped_stale,
                "rejected": {k.key: k.rejected for k in (self._joint_states, self._robot_state,
                                                         self._wrench, self._optical)}}

    def close(self, disable: bool | None = None) -> None:
        """Stop: optionally disable the robot, undeclare, close our session."""
        if disable is None:
            disable = self.config.disable_on_exit
        if disable and (self.dry_run or "enable" in self._publishers):
            try:
                self._send("enable", Bool(False))
            except Exception as exc:  # noqa: BLE001 - shutdown path: close the rest whatever happened
                log.warning("could not send disable: %s", exc)
        for entity in [*self._subscribers, *self._publishers.values()]:
            try:
                entity.undeclare()
            except Exception:  # noqa: BLE001 - best-effort close: the session may already be closing
                pass
        self._subscribers, self._publishers = [], {}
        if self._own_session and self._session is not None:
            try:
                self._session.close()
            except Exception as exc:  # noqa: BLE001 - best-effort close, reported
                log.warning("closing the Baxter session failed: %s", exc)
        self._session = None  # type: ignore[assignment]
        log.info("baxter backend closed", extra=kv(**{f"sent_{k}": v for k, v in self.sent.items()},
                                                   clamped=self.clamped))
