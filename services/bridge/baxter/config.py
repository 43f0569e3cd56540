"""Typed configuration of the Baxter backend (``[services.bridge.config.baxter]``)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from services.bridge.baxter.errors import BaxterConfigError

TopicName = Annotated[str, Meta(min_length=1, max_length=200, pattern=r"^/[A-Za-z0-9_/]+$")]
Seconds = Annotated[float, Meta(gt=0.0, le=60.0)]


class BaxterTopics(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """ROS 1 topic names on the robot side (``[services.bridge.config.baxter.topics]``).

    Attributes:
        joint_states: ``sensor_msgs/JointState`` of every joint (Baxter: 100 Hz).
        robot_state: ``baxter_core_msgs/AssemblyState`` (enabled, stopped, error, e-stop).
        joint_command: ``baxter_core_msgs/JointCommand`` to the right limb.
        joint_command_timeout: ``std_msgs/Float64``: the limb's own command time-out, s.
        enable: ``std_msgs/Bool`` to enable (True) or disable (False) the robot.
        gripper_command: ``baxter_core_msgs/EndEffectorCommand`` to the right gripper.
        wrist_wrench: ``geometry_msgs/WrenchStamped`` from the wrist F/T sensor driver.
        optical_motion: ``handover_msgs/OpticalMotion`` from the finger-pad optical sensor.
    """

    joint_states: TopicName = "/robot/joint_states"
    robot_state: TopicName = "/robot/state"
    joint_command: TopicName = "/robot/limb/right/joint_command"
    joint_command_timeout: TopicName = "/robot/limb/right/joint_command_timeout"
    enable: TopicName = "/robot/set_super_enable"
    gripper_command: TopicName = "/robot/end_effector/right_gripper/command"
    wrist_wrench: TopicName = "/handover/wrist_wrench"
    optical_motion: TopicName = "/handover/optical_motion"


class BaxterConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Baxter backend settings.

    Attributes:
        key_format: how the Zenoh ROS 1 bridge names keys: ``plugin`` (hex type/md5/[ns]/topic,
            zenoh-plugin-ros1 ≥ 0.11) or ``plain`` ([ns]/topic).
        key_namespace: the ROS 1 bridge's namespace (plugin) or key prefix (plain).
        topics: ROS topic names.
        startup_timeout_s: how long to wait for joint states and robot state at start, s.
        enable_on_start: send ``enable`` at start and wait for the robot to report enabled;
            when False the backend refuses to start on a robot that is not already enabled.
        disable_on_exit: send ``enable = False`` when the bridge stops.
        robot_command_timeout_s: sent to the limb's ``joint_command_timeout`` at start: the
            robot's own hold when commands stop, s (Baxter's default is 0.2 s).
        state_timeout_s: joint state older than this is stale: no command is sent, s.
        state_lost_timeout_s: no joint state for this long stops the bridge, s.
        limit_margin_rad: commands are clamped this far inside the URDF joint limits, rad.
        max_step_rad: a target farther than this from the measured position is clamped
            toward it (no jump after a stall), rad.
        gripper_id: the end effector's hardware id (Rethink electric gripper: 65538).
        gripper_force_full_scale_n: the grip force (N) that maps to the gripper's 100 % force.
        gripper_min_interval_s: at most one gripper command per this interval (the gripper's
            action loop runs at 20 Hz), s.
        gripper_deadband_percent: a grip change smaller than this is not resent, %.
        ft_rotation: 3×3 rotation (rows) from the F/T sensor frame to the gripper frame of
            the transfer loop (x toward the receiver, y down); identity when the sensor is
            mounted that way.
        ft_tare_samples: average this many wrench samples at start (gripper empty) and
            subtract them as the bias; 0: no tare.
        optical_rotation: 2×2 rotation (rows) from the optical sensor's x, y to the gripper
            frame's x, y.
        optical_counts_per_m: the optical sensor's resolution, counts/m (400 cpi = 15748).
        optical_min_quality: surface quality at or above which the surface is tracked.
        accel_filter_hz: first-order low-pass on the a_y estimate, Hz (0: off, as the sim).
    """

    key_format: Literal["plugin", "plain"] = "plugin"
    key_namespace: Annotated[str, Meta(max_length=100, pattern=r"^[A-Za-z0-9_/]*$")] = ""
    topics: BaxterTopics = BaxterTopics()
    startup_timeout_s: Seconds = 5.0
    enable_on_start: bool = False
    disable_on_exit: bool = False
    robot_command_timeout_s: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.2
    state_timeout_s: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.1
    state_lost_timeout_s: Seconds = 1.0
    limit_margin_rad: Annotated[float, Meta(ge=0.0, le=0.2)] = 0.01
    max_step_rad: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.25
    gripper_id: Annotated[int, Meta(ge=0, le=2**32 - 1)] = 65538
    gripper_force_full_scale_n: Annotated[float, Meta(gt=0.0, le=1000.0)] = 140.0
    gripper_min_interval_s: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.05
    gripper_deadband_percent: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.5
    ft_rotation: Annotated[list[Annotated[list[Annotated[float, Meta(ge=-1.0, le=1.0)]], Meta(max_length=3)]],
                           Meta(max_length=3)] = msgspec.field(
        default_factory=lambda: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    ft_tare_samples: Annotated[int, Meta(ge=0, le=10000)] = 0
    optical_rotation: Annotated[list[Annotated[list[Annotated[float, Meta(ge=-1.0, le=1.0)]], Meta(max_length=2)]],
                                Meta(max_length=2)] = msgspec.field(default_factory=lambda: [[1.0, 0.0], [0.0, 1.0]])
    optical_counts_per_m: Annotated[float, Meta(gt=0.0, le=1e7)] = 400.0 / 0.0254
    optical_min_quality: Annotated[int, Meta(ge=0, le=255)] = 1
    accel_filter_hz: Annotated[float, Meta(ge=0.0, le=500.0)] = 0.0

    def __post_init__(self) -> None:
        import numpy as np

        for name, size in (("ft_rotation", 3), ("optical_rotation", 2)):
            rows = getattr(self, name)
            if len(rows) != size or any(len(r) != size for r in rows):
                raise msgspec.ValidationError(f"{name} must be a {size}x{size} matrix - at `$.{name}`")
            m = np.array(rows, float)
            if not np.allclose(m @ m.T, np.eye(size), atol=1e-6):
                raise msgspec.ValidationError(f"{name} must be a rotation (orthonormal rows) - at `$.{name}`")
        if self.state_lost_timeout_s < self.state_timeout_s:
            raise msgspec.ValidationError("state_lost_timeout_s must be >= state_timeout_s")


def parse_baxter_config(table: dict[str, Any] | BaxterConfig) -> BaxterConfig:
    """Validate a ``[services.bridge.config.baxter]`` table.

    Raises:
        BaxterConfigError: naming the bad key.
    """
    if isinstance(table, BaxterConfig):
        return table
    try:
        return msgspec.convert(table, BaxterConfig)
    except msgspec.ValidationError as exc:
        raise BaxterConfigError(f"invalid [services.bridge.config.baxter]: {exc}") from None
