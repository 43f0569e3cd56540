"""The arm and the sensors at its wrist, as the bridge publishes them: joint state and command,
wrist force/torque, the finger pad's optical slip sensor.

Gripper frame of the transfer loop (thesis Fig. 15): x along the pull toward the receiver,
y DOWN (a positive `accel_y_m_s2` means the object accelerates downward), z = x × y.
"""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.types import (
    AccelMS2,
    JointEfforts,
    JointNames,
    JointPositions,
    JointVelocities,
    Vec3ForceN,
    Vec3TorqueNm,
    VelocityMS,
)


class JointState(Message, frozen=True, kw_only=True):
    """Measured joint state of the arm (100 Hz).

    Attributes:
        names: joint names (e.g. ``right_s0`` … ``right_w2``).
        position_rad, velocity_rad_s, effort_nm: per joint, same order as `names`.
        holding: True while the arm holds position because no fresh command arrived within
            the command time-out (200 ms) or a command was rejected.
        backend: ``sim``, ``baxter`` or ``franka``.
        enabled: the robot is enabled (always True in simulation).
    """

    names: JointNames
    position_rad: JointPositions
    velocity_rad_s: JointVelocities
    effort_nm: JointEfforts = []
    holding: bool = True
    backend: Literal["sim", "baxter", "franka"] = "sim"
    enabled: bool = True


class JointCommand(Message, frozen=True, kw_only=True):
    """Joint position command (100 Hz stream from the motion service).

    Attributes:
        names: joint names the positions refer to.
        position_rad: target joint positions (rad).
        velocity_rad_s: optional feed-forward velocities (rad/s); empty when not given.
        goal_id: the motion goal this command belongs to.
    """

    names: JointNames
    position_rad: JointPositions
    velocity_rad_s: JointVelocities = []
    goal_id: Annotated[str, Meta(max_length=64)] = ""


class WristWrench(Message, frozen=True, kw_only=True):
    """Wrist force/torque sensor reading at the base of the gripper (100 Hz).

    Attributes:
        force_n: (F_sx, F_sy, F_sz) in the gripper frame of the transfer loop
            (x toward the receiver, y down), N. Gravity of the gripper is compensated; the
            held object's weight is not.
        torque_nm: torques about the same axes, N m.
    """

    force_n: Vec3ForceN
    torque_nm: Vec3TorqueNm = (0.0, 0.0, 0.0)


class ObjectMotion(Message, frozen=True, kw_only=True):
    """Optical (mouse-type) sensor on the finger pad, with the derived estimates (≤ 1 kHz).

    Attributes:
        displacement_counts: relative displacement (x, y) since the previous sample, in
            sensor counts (gripper frame: x toward the receiver, y down).
        counts_per_m: sensor resolution (e.g. 400 cpi ≈ 15748 counts/m).
        dt_s: time covered by this sample, s.
        surface_valid: the object surface is over the sensor (False: counts are zero and the
            estimates are not to be trusted).
        velocity_m_s: estimated slip velocity (x, y), m/s.
        accel_y_m_s2: estimated acceleration along y (down positive), m/s², as used by the
            thesis's fail-safe law.
    """

    displacement_counts: tuple[
        Annotated[int, Meta(ge=-32768, le=32767)], Annotated[int, Meta(ge=-32768, le=32767)]
    ]
    counts_per_m: Annotated[float, Meta(gt=0.0, le=1e7)]
    dt_s: Annotated[float, Meta(gt=0.0, le=1.0)]
    surface_valid: bool = True
    velocity_m_s: tuple[VelocityMS, VelocityMS] = (0.0, 0.0)
    accel_y_m_s2: AccelMS2 = 0.0
