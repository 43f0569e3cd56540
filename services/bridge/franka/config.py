"""Typed configuration of the Franka backend (``[services.bridge.config.franka]``).

The joint names, limits and gripper figures live here (the profile's robot description,
`handover_model.robots`, does not drive this backend yet); the defaults are Franka's published
figures for the Panda (``model = "panda"``) or the FR3 (``model = "fr3"``), and any of them can
be overridden one by one.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
import numpy as np
from msgspec import Meta

from handover_model.robots import JointLimits
from services.bridge.franka.errors import FrankaConfigError

Floats7 = Annotated[list[Annotated[float, Meta(ge=-10.0, le=10.0)]], Meta(max_length=7)]

#: Franka's datasheet figures per model: joint position limits (rad), velocity limits (rad/s)
#: and torque limits (N m), joints 1–7 (Panda: "Robot and interface specifications",
#: libfranka docs; FR3: the FR3 product manual).
PRESETS: dict[str, dict[str, tuple[float, ...]]] = {
    "panda": {
        "lower_rad": (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973),
        "upper_rad": (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973),
        "velocity_rad_s": (2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100),
        "effort_nm": (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
    },
    "fr3": {
        "lower_rad": (-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159),
        "upper_rad": (2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159),
        "velocity_rad_s": (2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26),
        "effort_nm": (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
    },
}
JOINT_NAMES = {"panda": tuple(f"panda_joint{i}" for i in range(1, 8)),
               "fr3": tuple(f"fr3_joint{i}" for i in range(1, 8))}


class FrankaConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Franka backend settings.

    Attributes:
        host: the robot's FCI address (the Control box's "shop floor" interface, or the
            simulator's loopback address, e.g. ``127.0.0.2``).
        model: ``panda`` or ``fr3``: which datasheet the defaults below come from.
        joint_names: the seven joint names on the bus (empty: ``panda_joint1…7`` /
            ``fr3_joint1…7``).
        lower_rad, upper_rad, velocity_rad_s, effort_nm: per-joint overrides of the model's
            figures (7 values each; empty: the model's).
        limit_margin_rad: commands closer than this to a position limit are refused (the
            robot's own joint-limit reflex would stop it there), rad.
        max_step_rad: a command farther than this from the previous target (from the
            measured position when holding) is refused (a jump, not a trajectory), rad.
        relative_dynamics_factor: scales the robot's velocity, acceleration and jerk limits
            for following commands (0.05–1.0); stops always use the full limits.
        position_gain_per_s: the bridge's position loop: commanded velocity = feed-forward +
            gain × (target − measured), 1/s.
        robot_command_timeout_s: each velocity command is held this long on the robot; with
            no newer one the robot brakes by itself (a stalled bridge), s.
        connect_timeout_s: keep trying to reach the robot this long at start (a simulator
            or a Control box still starting up), s.
        state_lost_timeout_s: the robot's clock did not advance for this long: the robot is
            lost, the bridge stops with the fault, s.
        realtime: ``enforce`` (a PREEMPT_RT kernel is required, as on a real robot) or
            ``ignore`` (a simulator on a desktop kernel).
        recover_on_start: run the robot's automatic error recovery at start (else a robot in
            an error state refuses the start, for a person to look first).
        torque_threshold_nm, force_threshold_n: the collision reflex thresholds set at start.
        gripper: drive the Franka Hand (False: an arm without a hand, grip commands ignored).
        gripper_max_force_n: grasp force limit, N (the Hand: 70 N continuous, 140 N peak).
        gripper_min_force_n: a grip command below this opens the hand, N.
        gripper_speed_m_s: finger speed for grasping and opening, m/s (the Hand: ≤ 0.1 m/s
            for both fingers together).
        gripper_deadband_n: a grasp force change smaller than this is not sent again, N.
        gripper_min_interval_s: at most one new grasp per this interval (each grasp is a
            whole action on the Hand, not a force set-point), s; opening is never delayed.
    """

    host: Annotated[str, Meta(min_length=1, max_length=253, pattern=r"^[A-Za-z0-9.:\-]+$")] = "172.16.0.2"
    model: Literal["panda", "fr3"] = "panda"
    joint_names: Annotated[list[Annotated[str, Meta(min_length=1, max_length=64)]], Meta(max_length=7)] = []
    lower_rad: Floats7 = []
    upper_rad: Floats7 = []
    velocity_rad_s: Annotated[list[Annotated[float, Meta(gt=0.0, le=10.0)]], Meta(max_length=7)] = []
    effort_nm: Annotated[list[Annotated[float, Meta(gt=0.0, le=500.0)]], Meta(max_length=7)] = []
    limit_margin_rad: Annotated[float, Meta(ge=0.0, le=0.5)] = 0.05
    max_step_rad: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.1
    relative_dynamics_factor: Annotated[float, Meta(ge=0.05, le=1.0)] = 0.5
    position_gain_per_s: Annotated[float, Meta(ge=0.0, le=50.0)] = 5.0
    robot_command_timeout_s: Annotated[float, Meta(ge=0.02, le=1.0)] = 0.05
    state_lost_timeout_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.2
    connect_timeout_s: Annotated[float, Meta(ge=0.0, le=120.0)] = 10.0
    realtime: Literal["enforce", "ignore"] = "enforce"
    recover_on_start: bool = False
    torque_threshold_nm: Annotated[float, Meta(gt=0.0, le=100.0)] = 20.0
    force_threshold_n: Annotated[float, Meta(gt=0.0, le=100.0)] = 30.0
    gripper: bool = True
    gripper_max_force_n: Annotated[float, Meta(gt=0.0, le=140.0)] = 70.0
    gripper_min_force_n: Annotated[float, Meta(ge=0.0, le=140.0)] = 1.0
    gripper_speed_m_s: Annotated[float, Meta(gt=0.0, le=0.1)] = 0.05
    gripper_deadband_n: Annotated[float, Meta(ge=0.0, le=20.0)] = 2.0
    gripper_min_interval_s: Annotated[float, Meta(ge=0.0, le=2.0)] = 0.1

    def __post_init__(self) -> None:
        for name in ("joint_names", "lower_rad", "upper_rad", "velocity_rad_s", "effort_nm"):
            values = getattr(self, name)
            if values and len(values) != 7:
                raise msgspec.ValidationError(f"{name} needs 7 values (one per joint), got {len(values)} "
                                              f"- at `$.{name}`")
        limits = self.limits()
        if np.any(limits.lower_rad >= limits.upper_rad):
            raise msgspec.ValidationError("every lower_rad must be below its upper_rad (margin included)")

    def names(self) -> tuple[str, ...]:
        """The joint names on the bus."""
        return tuple(self.joint_names) or JOINT_NAMES[self.model]

    def limits(self) -> JointLimits:
        """The limits commands are checked against: the model's (or the overrides), with the
        position limits pulled in by `limit_margin_rad`."""
        preset = PRESETS[self.model]

        def pick(name: str) -> np.ndarray:
            return np.array(getattr(self, name) or preset[name], float)

        return JointLimits(lower_rad=pick("lower_rad") + self.limit_margin_rad,
                           upper_rad=pick("upper_rad") - self.limit_margin_rad,
                           velocity_rad_s=pick("velocity_rad_s"), effort_nm=pick("effort_nm"))


def parse_franka_config(table: dict[str, Any] | FrankaConfig) -> FrankaConfig:
    """Validate a ``[services.bridge.config.franka]`` table.

    Raises:
        FrankaConfigError: naming the bad key.
    """
    if isinstance(table, FrankaConfig):
        return table
    try:
        return msgspec.convert(table, FrankaConfig)
    except msgspec.ValidationError as exc:
        raise FrankaConfigError(f"invalid [services.bridge.config.franka]: {exc}") from None
