"""What the fake Baxter publishes: the simulation's readings as the robot's ROS 1 messages.

Pure functions, no bus: `services.bridge.baxter.fake` calls them each tick with the headers
it numbers and stamps. Units as ROS: rad, rad/s, N m, N, m; optical counts in sensor counts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from services.bridge.backend import JointReading
from services.bridge.baxter.messages import Header, JointState, OpticalMotion, Vector3, Wrench, WrenchStamped

#: Baxter's /robot/joint_states names (17 joints, alphabetical as the robot sends them).
BAXTER_JOINTS: tuple[str, ...] = (
    "head_nod", "head_pan", "left_e0", "left_e1", "left_s0", "left_s1", "left_w0", "left_w1",
    "left_w2", "right_e0", "right_e1", "right_s0", "right_s1", "right_w0", "right_w1", "right_w2",
    "torso_t0",
)
GRIPPER_JOINTS: tuple[str, ...] = ("right_gripper_l_finger_joint", "right_gripper_r_finger_joint")
#: Finger joint position of the open gripper, m (closed: 0).
GRIPPER_OPEN_FINGER_M = 0.02
#: Standard gravity, m/s² (the static weight felt without the contact plant).
GRAVITY_M_S2 = 9.81


def arm_joint_state(header: Header, arm_joints: Sequence[str], reading: JointReading) -> JointState:
    """Baxter's 17-joint state: the simulated arm's joints (`reading`, rad, rad/s, N m, in
    `arm_joints` order) at their places; every joint the sim does not move reads 0."""
    arm = dict(zip(arm_joints, zip(reading.position_rad, reading.velocity_rad_s, reading.effort_nm,
                                   strict=True), strict=True))
    pos, vel, eff = [], [], []
    for name in BAXTER_JOINTS:
        p, v, e = arm.get(name, (0.0, 0.0, 0.0))
        pos.append(float(p))
        vel.append(float(v))
        eff.append(float(e))
    return JointState(header=header, name=BAXTER_JOINTS, position=tuple(pos), velocity=tuple(vel),
                      effort=tuple(eff))


def gripper_joint_state(header: Header, closed: bool) -> JointState:
    """The gripper-only joint state Baxter's end-effector publisher sends: finger positions, m
    (0 closed, ±`GRIPPER_OPEN_FINGER_M` open), no velocity or effort."""
    finger_m = 0.0 if closed else GRIPPER_OPEN_FINGER_M
    return JointState(header=header, name=GRIPPER_JOINTS, position=(finger_m, -finger_m), velocity=(0.0, 0.0),
                      effort=(0.0, 0.0))


def static_weight_wrench(object_mass_kg: float, gripping: bool) -> dict[str, Any]:
    """The wrench without the contact plant, in the gripper frame: the object's weight, N,
    along the gripper's y (down) while it is gripped, else nothing."""
    weight_n = object_mass_kg * GRAVITY_M_S2 if gripping else 0.0
    return {"force_n": (0.0, weight_n, 0.0), "torque_nm": (0.0, 0.0, 0.0)}


def wrist_wrench(header: Header, wrench: Mapping[str, Any], ft_rotation: np.ndarray) -> WrenchStamped:
    """The F/T sensor's message: `wrench` (``force_n``, optional ``torque_nm``, gripper frame)
    turned into the sensor frame; `ft_rotation` is R with gripper = R sensor."""
    force_n = ft_rotation.T @ np.asarray(wrench["force_n"], float)
    torque_nm = ft_rotation.T @ np.asarray(wrench.get("torque_nm", (0.0, 0.0, 0.0)), float)
    return WrenchStamped(header=header, wrench=Wrench(force=Vector3(*map(float, force_n)),
                                                      torque=Vector3(*map(float, torque_nm))))


def optical_motion(header: Header, motion: Mapping[str, Any], optical_rotation: np.ndarray) -> OpticalMotion:
    """The optical sensor's message: `motion` (``displacement_counts`` in the gripper frame,
    ``dt_s``, ``surface_valid``) with the counts turned into the sensor frame (R with
    gripper = R sensor) and rounded; surface quality 100 on a valid surface, else 0."""
    counts = optical_rotation.T @ np.asarray(motion["displacement_counts"], float)
    return OpticalMotion(header=header, dx_counts=int(round(counts[0])), dy_counts=int(round(counts[1])),
                         dt=float(motion["dt_s"]), surface_quality=100 if motion["surface_valid"] else 0)
