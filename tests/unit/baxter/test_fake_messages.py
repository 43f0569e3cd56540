"""The fake Baxter's outgoing messages, read back the way the Baxter backend reads them: ROS 1
bytes decoded, joints selected, sensor frames turned back into the gripper frame."""

from __future__ import annotations

import numpy as np
import pytest

from services.bridge.backend import JointReading
from services.bridge.baxter import core
from services.bridge.baxter.fake_messages import (
    BAXTER_JOINTS,
    GRIPPER_JOINTS,
    arm_joint_state,
    gripper_joint_state,
    optical_motion,
    static_weight_wrench,
    wrist_wrench,
)
from services.bridge.baxter.messages import Header, JointState, OpticalMotion, WrenchStamped
from services.bridge.baxter.ros1 import Time

RIGHT_ARM = ("right_s0", "right_s1", "right_e0", "right_e1", "right_w0", "right_w1", "right_w2")
HEADER = Header(seq=3, stamp=Time(10, 20), frame_id="f")
# Sensor z along the gripper's x, sensor x along gripper y (as test_core's converter case).
FT_ROTATION = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
OPTICAL_ROTATION = np.array([[0.0, -1.0], [1.0, 0.0]])  # sensor x, y → gripper y, −x


def test_arm_joint_state_places_the_arm_in_baxters_17_joints():
    reading = JointReading(position_rad=np.arange(7) * 0.1, velocity_rad_s=np.arange(7) * -0.2,
                           effort_nm=np.arange(7) + 1.0)
    msg = JointState.from_bytes(arm_joint_state(HEADER, RIGHT_ARM, reading).to_bytes())
    assert msg.header == HEADER and msg.name == BAXTER_JOINTS and len(msg.name) == 17
    position, velocity, effort = core.select_joints(msg, RIGHT_ARM)
    np.testing.assert_array_equal(position, reading.position_rad)
    np.testing.assert_array_equal(velocity, reading.velocity_rad_s)
    np.testing.assert_array_equal(effort, reading.effort_nm)
    others = [i for i, name in enumerate(BAXTER_JOINTS) if name not in RIGHT_ARM]
    assert len(others) == 10
    assert all(msg.position[i] == msg.velocity[i] == msg.effort[i] == 0.0 for i in others)


def test_gripper_joint_state_is_fingers_only_and_not_an_arm_reading():
    closed = gripper_joint_state(HEADER, closed=True)
    opened = gripper_joint_state(HEADER, closed=False)
    assert closed.name == opened.name == GRIPPER_JOINTS
    assert closed.position == (0.0, 0.0) and opened.position == (0.02, -0.02)
    assert opened.velocity == opened.effort == (0.0, 0.0)
    assert core.select_joints(JointState.from_bytes(opened.to_bytes()), RIGHT_ARM) is None


def test_static_weight_only_while_gripping():
    assert static_weight_wrench(0.5, gripping=True) == {"force_n": (0.0, 0.5 * 9.81, 0.0),
                                                        "torque_nm": (0.0, 0.0, 0.0)}
    assert static_weight_wrench(0.5, gripping=False)["force_n"] == (0.0, 0.0, 0.0)


def test_wrist_wrench_is_in_the_sensor_frame_the_backend_turns_back():
    gripper_force_n, gripper_torque_nm = (5.0, 1.962, -0.5), (0.1, -0.2, 0.3)
    msg = wrist_wrench(HEADER, {"force_n": gripper_force_n, "torque_nm": gripper_torque_nm}, FT_ROTATION)
    msg = WrenchStamped.from_bytes(msg.to_bytes())
    assert msg.header == HEADER
    w = msg.wrench
    assert (w.force.x, w.force.y, w.force.z) == pytest.approx((1.962, -0.5, 5.0))
    force_n, torque_nm = core.WrenchConverter(FT_ROTATION).convert(
        (w.force.x, w.force.y, w.force.z), (w.torque.x, w.torque.y, w.torque.z))
    assert force_n == pytest.approx(gripper_force_n) and torque_nm == pytest.approx(gripper_torque_nm)
    no_torque = wrist_wrench(HEADER, {"force_n": gripper_force_n}, FT_ROTATION).wrench.torque
    assert (no_torque.x, no_torque.y, no_torque.z) == (0.0, 0.0, 0.0)


def test_optical_motion_counts_in_the_sensor_frame_the_backend_turns_back():
    motion = {"displacement_counts": (12, -7), "dt_s": 0.01, "surface_valid": True}
    msg = OpticalMotion.from_bytes(optical_motion(HEADER, motion, OPTICAL_ROTATION).to_bytes())
    assert msg.header == HEADER and (msg.dx_counts, msg.dy_counts) == (-7, -12)
    assert msg.dt == pytest.approx(0.01) and msg.surface_quality == 100
    sample = core.OpticalEstimator(OPTICAL_ROTATION, counts_per_m=10000.0).to_gripper(
        msg.dx_counts, msg.dy_counts, msg.dt, msg.surface_quality, min_quality=1)
    assert (sample.dx_counts, sample.dy_counts) == (12.0, -7.0) and sample.surface_valid
    lost = optical_motion(HEADER, {"displacement_counts": (0.4, 2.6), "dt_s": 0.02, "surface_valid": False},
                          np.eye(2))
    assert (lost.dx_counts, lost.dy_counts, lost.surface_quality) == (0, 3, 0)
