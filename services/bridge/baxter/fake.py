"""A fake Baxter: speaks the robot's ROS 1 bytes on the same Zenoh keys, moves like the sim.

``python -m services.bridge.baxter.fake --profile <profile>`` stands in for the robot side
(Baxter + its sensors + zenoh-bridge-ros1) so the Baxter backend runs end to end without a
robot. Its physics is the bridge's own simulation backend (`make_backend("sim", …)`: the arm
servo `robot_sim.arm.SimulatedArm`, and with ``contact.enabled`` the contact plant or the whole
handover scene), driven the way Baxter drives its arm:

- ``/robot/limb/right/joint_command`` (``JointCommand``, position mode) sets the servo target
  while the robot is enabled; no command for the limb's time-out (0.2 s, or what
  ``joint_command_timeout`` set) → the arm holds where it is; a disabled robot does not move;
- ``/robot/set_super_enable`` (``Bool``) enables/disables it (``refuse_enable`` ignores it);
- ``/robot/end_effector/right_gripper/command`` (``EndEffectorCommand`` ``go``) sets the grip:
  force % × ``gripper_force_full_scale_n`` when closing (position < 50 %), 0 when opening;
- publishes at ``rate_hz`` (100 Hz) ``/robot/joint_states`` with Baxter's 17 joints, and every
  tenth tick a gripper-only joint state (Baxter's end-effector publisher does that too),
  ``/robot/state`` (``AssemblyState``), the wrist wrench (``WrenchStamped``, in the sensor frame
  given by ``ft_rotation``) and the optical sensor (``OpticalMotion``, counts in the sensor
  frame given by ``optical_rotation``) from the simulated sensors; without the contact plant
  the wrench is the object's static weight along the gripper's y (down) while the gripper
  is closed;
- with ``publish_truth`` it also publishes the simulation's ``sim/truth`` on the bus (what
  really happened, for summaries and tests; a real robot has none).

The full handover (``contact.scenario = "handover"``): the physics is the sim's
`HandoverSimBackend` (object on the table, pick, the receiver's reach, the contact
transfer). The receiver is not part of Baxter: on real hardware a Kinect driver publishes
``perception/skeleton`` and ``perception/depth``. Here the fake plays that role too: with
``kinect.enabled`` it runs the simulated Kinect (`services.sim_kinect.thread.KinectThread`,
30 Hz, on a thread of this process) on the scene's own receiver hand and object, so the
skeleton the tracker sees and the hand that takes the object are the same hand, and
publishes the Kinect's ground truth on ``sim/kinect_truth``. It follows
``supervisor/state``: a new ``episode_id`` puts the object back on the table and the
receiver's hand at rest (the lab assistant resetting the scene). The Baxter backend itself
knows nothing of this.

Configuration: ``[services.fake_baxter.config]`` of the profile (see `FakeBaxterConfig`); the
ROS topics and key format come from ``[services.bridge.config.baxter]`` so both sides agree.
It joins the bus as the service ``fake_baxter`` (liveliness token, bus user ``fake_baxter``).
"""

from __future__ import annotations

import argparse
import logging
import threading
import time
from typing import Annotated, Any

import msgspec
import numpy as np
import zenoh
from msgspec import Meta

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_JOINTS
from services.bridge.backend import Backend, make_backend
from services.bridge.baxter.config import BaxterConfig, parse_baxter_config
from services.bridge.baxter.core import grip_force_from_percent, parse_gripper_args
from services.bridge.baxter.errors import BaxterConfigError
from services.bridge.baxter.fake_openni import FakeOpenNIConfig, camera_thread, fake_ros1_config
from services.bridge.baxter.fake_messages import (
    arm_joint_state,
    gripper_joint_state,
    optical_motion,
    static_weight_wrench,
    wrist_wrench,
)
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import (
    AssemblyState,
    Bool,
    EndEffectorCommand,
    Float64,
    Header,
    JointCommand,
    JointState,
    OpticalMotion,
    WrenchStamped,
)
from services.bridge.baxter.ros1 import Ros1DecodeError, Ros1Message, Time
from services.bridge.config import ContactConfig
from services.runtime import Profile, RateLimitedLog, ServiceNode, base_parser, kv, load_profile, run_main
from services.sim_kinect.config import KinectConfig
from services.sim_kinect.config import parse_config as parse_kinect_config
from services.sim_kinect.errors import KinectConfigError
from services.tracker.ros1.config import Ros1KinectConfig

log = logging.getLogger(__name__)

SERVICE_NAME = "fake_baxter"

class FakeBaxterConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """The fake robot (``[services.fake_baxter.config]``).

    Attributes:
        rate_hz: publication and simulation rate, Hz (Baxter: 100).
        enabled: the robot starts enabled.
        refuse_enable: ignore enable requests (a robot that cannot be enabled).
        servo_time_constant_s: the arm servo's lag, s (as the sim backend).
        command_timeout_s: the limb's command time-out until told otherwise, s.
        gripper_force_full_scale_n: grip force at 100 % force setting, N (as the backend).
        object_mass_kg: static weight felt when the gripper is closed without contact plant.
        contact: the contact plant / handover scene (as ``[services.bridge.config.contact]``;
            its ``height_m`` and ``posture`` are replaced by the Kinect's: one receiver).
        kinect: the simulated Kinect standing in for the Kinect driver (as
            ``[services.kinect.config]``; off by default; its height and posture are also the
            scene receiver's body).
        openni: send the Kinect as openni_tracker's ``/tf`` and a depth image, ROS 1 bytes
            (`services.bridge.baxter.fake_openni`), instead of `perception/*` on the bus.
        publish_truth: publish ``sim/truth`` on the bus.
    """

    rate_hz: Annotated[float, Meta(ge=1.0, le=1000.0)] = 100.0
    enabled: bool = True
    refuse_enable: bool = False
    servo_time_constant_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.05
    command_timeout_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.2
    gripper_force_full_scale_n: Annotated[float, Meta(gt=0.0, le=1000.0)] = 140.0
    object_mass_kg: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.2
    contact: ContactConfig = ContactConfig()
    kinect: KinectConfig = KinectConfig(enabled=False)
    openni: FakeOpenNIConfig = FakeOpenNIConfig()
    publish_truth: bool = True


def make_physics(config: FakeBaxterConfig) -> Backend:
    """The sim backend the fake moves with (arm servo; contact plant or handover scene)."""
    contact = msgspec.structs.replace(config.contact, height_m=config.kinect.height_m,
                                      posture=config.kinect.posture)
    return make_backend("sim", contact=contact, time_constant_s=config.servo_time_constant_s)


class FakeBaxter:
    """The fake robot's state machine over an open bus node (see module docstring)."""

    def __init__(self, node: ServiceNode, config: FakeBaxterConfig, baxter: BaxterConfig,
                 physics: Backend | None = None, ros1: Ros1KinectConfig | None = None) -> None:
        self.node = node
        self.config = config
        self.baxter = baxter
        self.physics = physics or make_physics(config)
        # Only the handover scene has these (see services/bridge/handover_backend.py).
        self._new_episode = getattr(self.physics, "new_episode", None)
        self._scene_snapshot = getattr(self.physics, "scene_snapshot", None)
        self.episode_id: int | None = None
        self.scene_resets = 0
        self.enabled = config.enabled
        self.command_timeout_s = config.command_timeout_s
        self.grip_n = 0.0
        self.gripper_closed = False
        self.commands = 0
        self.ignored_commands = 0
        self._last_command_s = -np.inf
        self._following = False
        self._seq = 0
        self._lock = threading.Lock()
        self._bad = RateLimitedLog(log, 1.0)
        self._ft_rotation = np.array(baxter.ft_rotation, float)
        self._optical_rotation = np.array(baxter.optical_rotation, float)

        def key(topic: str, cls: type[Ros1Message]) -> str:
            return topic_key(topic, cls.TYPE, baxter.key_format, baxter.key_namespace)

        t = baxter.topics
        self.keys = {
            "joint_states": key(t.joint_states, JointState), "robot_state": key(t.robot_state, AssemblyState),
            "wrist_wrench": key(t.wrist_wrench, WrenchStamped), "optical_motion": key(t.optical_motion, OpticalMotion),
            "joint_command": key(t.joint_command, JointCommand),
            "joint_command_timeout": key(t.joint_command_timeout, Float64),
            "enable": key(t.enable, Bool), "gripper_command": key(t.gripper_command, EndEffectorCommand),
        }
        session = node.session
        self._pubs = {name: session.declare_publisher(self.keys[name]) for name in
                      ("joint_states", "robot_state", "wrist_wrench", "optical_motion")}
        self._inbox: list[tuple[str, Ros1Message]] = []
        handlers = {"joint_command": JointCommand, "joint_command_timeout": Float64, "enable": Bool,
                    "gripper_command": EndEffectorCommand}
        self._subs = [session.declare_subscriber(self.keys[name], self._callback(name, cls))
                      for name, cls in handlers.items()]
        self._truth_pub = node.publisher(topics.SIM_TRUTH) if config.publish_truth else None
        self._supervisor = node.subscribe(topics.SUPERVISOR_STATE, queue_size=16) if self._new_episode else None
        self.kinect = camera_thread(config.kinect, config.openni, node, ros1)
        if self.kinect is not None:
            self._update_kinect()
            self.kinect.start()

    def _update_kinect(self) -> None:
        """Hand the arm posture (and the scene's receiver hand and object) to the Kinect."""
        if self.kinect is None:
            return
        q = self.physics.read().position_rad
        if self._scene_snapshot is not None:
            self.kinect.update_arm(q, *self._scene_snapshot())
        else:
            self.kinect.update_arm(q)

    def _follow_episodes(self) -> None:
        """A new supervisor episode resets the scene (object on the table, hand at rest)."""
        if self._supervisor is None:
            return
        for rx in self._supervisor.drain():
            if self.episode_id is not None and rx.msg.episode_id != self.episode_id:
                log.info("new episode: scene reset", extra=kv(episode_id=rx.msg.episode_id))
                self._new_episode()
                self.scene_resets += 1
            self.episode_id = rx.msg.episode_id

    # Zenoh thread: decode and queue only.
    def _callback(self, name: str, cls: type[Ros1Message]):
        def on_sample(sample: zenoh.Sample) -> None:
            try:
                msg = cls.from_bytes(sample.payload.to_bytes())
            except Ros1DecodeError as exc:
                self._bad.warning(name, f"fake baxter dropped a bad {cls.TYPE}: {exc}")
                return
            with self._lock:
                self._inbox.append((name, msg))
        return on_sample

    def _handle(self, now_s: float) -> None:
        with self._lock:
            inbox, self._inbox = self._inbox, []
        for name, msg in inbox:
            if name == "enable":
                wanted = bool(msg.data)  # type: ignore[attr-defined]
                if wanted and self.config.refuse_enable:
                    log.warning("fake baxter refuses to enable (refuse_enable)")
                    continue
                if wanted != self.enabled:
                    log.info("fake baxter %s", "enabled" if wanted else "disabled")
                self.enabled = wanted
            elif name == "joint_command_timeout":
                value = float(msg.data)  # type: ignore[attr-defined]
                if np.isfinite(value) and value > 0:
                    self.command_timeout_s = value
            elif name == "joint_command":
                self._joint_command(msg, now_s)  # type: ignore[arg-type]
            elif name == "gripper_command":
                self._gripper_command(msg)  # type: ignore[arg-type]

    def _joint_command(self, msg: JointCommand, now_s: float) -> None:
        if not self.enabled or msg.mode != JointCommand.POSITION_MODE or len(msg.names) != len(msg.command):
            self.ignored_commands += 1
            return
        target = self.physics.arm.target_rad.copy() if self._following else self.physics.read().position_rad
        index = {n: i for i, n in enumerate(RIGHT_ARM_JOINTS)}
        for name, value in zip(msg.names, msg.command, strict=True):
            if name in index and np.isfinite(value):
                target[index[name]] = value
        self.physics.command(target)
        self._following = True
        self._last_command_s = now_s
        self.commands += 1

    def _gripper_command(self, msg: EndEffectorCommand) -> None:
        if msg.command != EndEffectorCommand.CMD_GO:
            return
        try:
            position, force = parse_gripper_args(msg.args)
        except ValueError as exc:
            self._bad.warning("grip", f"fake baxter ignored a gripper command: {exc}")
            return
        self.gripper_closed = position < 50.0
        self.grip_n = (grip_force_from_percent(force, self.config.gripper_force_full_scale_n) if self.gripper_closed
                       else 0.0)
        self.physics.gripper_command(self.grip_n)

    def tick(self, dt_s: float) -> None:
        now_s = time.monotonic()
        self._handle(now_s)
        self._follow_episodes()
        if not self.enabled or now_s - self._last_command_s > self.command_timeout_s:
            if self._following or not self.enabled:
                self.physics.hold()
            self._following = False
        self.physics.step(dt_s)
        self._publish()
        self._update_kinect()

    def _header(self, frame_id: str = "") -> Header:
        self._seq += 1
        return Header(seq=self._seq, stamp=Time.from_ns(time.time_ns()), frame_id=frame_id)

    def _publish(self) -> None:
        self._put("joint_states", arm_joint_state(self._header(), RIGHT_ARM_JOINTS, self.physics.read()))
        if self._seq % 10 == 0:
            self._put("joint_states", gripper_joint_state(self._header(), self.gripper_closed))
        self._put("robot_state", AssemblyState(ready=self.enabled, enabled=self.enabled))
        captured: dict[str, dict[str, Any]] = {}
        self.physics.publish_extras(lambda suffix, fields: captured.__setitem__(suffix, fields))
        wrench = captured.get("sensors/wrist_wrench")
        if wrench is None and not self.config.contact.enabled:
            wrench = static_weight_wrench(self.config.object_mass_kg, self.gripper_closed and self.grip_n > 0)
        if wrench is not None:
            self._put("wrist_wrench", wrist_wrench(self._header("right_wrist_ft"), wrench, self._ft_rotation))
        motion = captured.get("sensors/object_motion")
        if motion is not None:
            self._put("optical_motion", optical_motion(self._header("right_finger_optical"), motion,
                                                       self._optical_rotation))
        truth = captured.get("sim/truth")
        if truth is not None and self._truth_pub is not None:
            self._truth_pub.put(**truth)

    def _put(self, name: str, msg: Ros1Message) -> None:
        self._pubs[name].put(msg.to_bytes())

    def close(self) -> None:
        if self.kinect is not None:
            self.kinect.stop()
        for entity in [*self._subs, *self._pubs.values()]:
            try:
                entity.undeclare()
            except Exception:  # noqa: BLE001 - best-effort close: the session may already be closing
                pass


def parse_fake_config(table: dict[str, Any]) -> FakeBaxterConfig:
    try:
        config = msgspec.convert(table, FakeBaxterConfig)
    except msgspec.ValidationError as exc:
        raise BaxterConfigError(f"invalid [services.fake_baxter.config]: {exc}") from None
    try:  # the same checks as the kinect service's own table (e.g. a 3-value hand target)
        parse_kinect_config(dict(table.get("kinect", {})), "[services.fake_baxter.config.kinect]")
    except KinectConfigError as exc:
        raise BaxterConfigError(str(exc)) from None
    return config


def run_fake(profile: Profile, config: FakeBaxterConfig, baxter: BaxterConfig,
             ros1: Ros1KinectConfig | None = None) -> int:
    # Build the physics (URDF, scene) before joining the bus: once the liveliness token is up,
    # the supervisor expects a heartbeat every 50 ms.
    physics = make_physics(config)
    with ServiceNode(SERVICE_NAME, profile) as node:
        fake = FakeBaxter(node, config, baxter, physics, ros1)
        log.info("fake baxter running", extra=kv(enabled=fake.enabled, rate_hz=config.rate_hz,
                                                 joint_states=fake.keys["joint_states"]))
        last_s = time.monotonic()
        try:
            for _ in node.loop(config.rate_hz):
                now_s = time.monotonic()
                fake.tick(now_s - last_s)
                last_s = now_s
        finally:
            fake.close()
            log.info("fake baxter stopped", extra=kv(commands=fake.commands, ignored=fake.ignored_commands,
                                                     scene_resets=fake.scene_resets,
                                                     kinect_frames=fake.kinect.frames if fake.kinect else 0))
    return 0


def _run(args: argparse.Namespace) -> int:
    profile = load_profile(args)
    table = profile.service_config(SERVICE_NAME)
    if args.disabled:
        table["enabled"] = False
    if args.refuse_enable:
        table["refuse_enable"] = True
    contact = dict(table.get("contact", {}))
    if args.receiver:
        contact["behaviour"] = args.receiver
    if args.seed is not None:
        contact["seed"] = args.seed
    if contact:
        table["contact"] = contact
    kinect = dict(table.get("kinect", {}))
    if args.posture:
        kinect["posture"] = args.posture
    if kinect:
        table["kinect"] = kinect
    if args.openni:
        table["openni"] = {**table.get("openni", {}), "enabled": True}
    baxter = parse_baxter_config(profile.service_config("bridge").get("baxter", {}))
    return run_fake(profile, parse_fake_config(table), baxter, fake_ros1_config(profile))


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-fake-baxter",
        "Fake Baxter for tests: answers the Baxter backend with the robot's ROS 1 bytes on the "
        "same Zenoh keys, moving like the simulated arm.")
    parser.set_defaults(service_name=SERVICE_NAME)
    parser.add_argument("--disabled", action="store_true", help="start with the robot disabled")
    parser.add_argument("--refuse-enable", action="store_true", help="ignore enable requests")
    parser.add_argument("--openni", action="store_true", help="send the Kinect as openni_tracker /tf and a depth "
                        "image in ROS 1 bytes (the tracker's sensor = \"ros1\"), not on perception/*")
    scene = parser.add_argument_group("the simulated handover scene (contact.scenario = \"handover\")")
    scene.add_argument("--receiver", choices=["taking", "dropping", "bumping", "hesitating", "absent"],
                       default=None, help="the receiver's behaviour (default: the profile's)")
    scene.add_argument("--posture", choices=["standing", "sitting"], default=None,
                       help="the receiver's posture (default: the profile's)")
    scene.add_argument("--seed", type=int, default=None, help="seed of the scene's noise")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
