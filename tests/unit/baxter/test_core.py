"""Pure logic of the Baxter backend: safety clamps, robot state, gripper mapping, sensor
conversions, and the Zenoh key mapping of zenoh-plugin-ros1."""

from __future__ import annotations

import json

import numpy as np
import pytest

from services.bridge.baxter import core
from services.bridge.baxter.config import parse_baxter_config
from services.bridge.baxter.errors import BaxterConfigError
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import AssemblyState, Header, JointState


def test_clamp_keeps_commands_inside_shrunk_limits_and_near_the_arm():
    lower, upper = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    result = core.clamp_command(np.array([2.0, 0.1]), np.array([0.9, 0.0]), lower, upper, 0.05, 0.25)
    assert result.target_rad == pytest.approx([0.95, 0.1])
    assert result.limited == (0,) and result.stepped == ()
    far = core.clamp_command(np.array([-0.9, 0.0]), np.array([0.5, 0.0]), lower, upper, 0.0, 0.25)
    assert far.target_rad == pytest.approx([0.25, 0.0]) and far.stepped == (0,)


def test_robot_state_problems_name_the_cause():
    assert core.robot_state_problem(AssemblyState(enabled=True, ready=True)) == ""
    assert "not enabled" in core.robot_state_problem(AssemblyState())
    assert "e-stop button" in core.robot_state_problem(AssemblyState(enabled=True, stopped=True, estop_source=1))
    assert "no robot state" in core.robot_state_problem(None)


def test_select_joints_ignores_gripper_only_and_inconsistent_messages():
    names = ("right_s0", "right_s1")
    full = JointState(header=Header(), name=("left_s0", "right_s1", "right_s0"), position=(9.0, 0.2, 0.1),
                      velocity=(0.0, 2.0, 1.0), effort=())
    pos, vel, eff = core.select_joints(full, names)
    assert pos.tolist() == [0.1, 0.2] and vel.tolist() == [1.0, 2.0] and eff.tolist() == [0.0, 0.0]
    assert core.select_joints(JointState(name=("right_gripper_l_finger_joint",), position=(0.0,)), names) is None
    assert core.select_joints(JointState(name=names, position=(0.1,)), names) is None
    assert core.select_joints(JointState(name=names, position=(0.1, float("nan"))), names) is None


def test_gripper_go_command_maps_force_to_percent_and_back():
    cmd = core.gripper_go_command(35.0, 140.0, 65538, 4)
    args = json.loads(cmd.args)
    assert cmd.command == "go" and cmd.id == 65538 and cmd.sequence == 4
    assert args == {"position": 0.0, "force": 25.0}
    assert core.parse_gripper_args(cmd.args) == (0.0, 25.0)
    assert core.grip_force_from_percent(25.0, 140.0) == pytest.approx(35.0)
    assert json.loads(core.gripper_go_command(0.0, 140.0, 1, 1).args)["position"] == 100.0
    assert core.grip_percent(1e6, 140.0) == 100.0 and core.grip_percent(float("nan"), 140.0) == 0.0
    with pytest.raises(ValueError):
        core.parse_gripper_args('{"position": 150}')


def test_gripper_throttle_rate_deadband_and_immediate_release():
    throttle = core.GripperThrottle(min_interval_s=0.05, deadband_percent=0.5)
    assert throttle.should_send(20.0, 0.0)
    assert not throttle.should_send(20.3, 0.1)       # inside the dead band
    assert not throttle.should_send(30.0, 0.02)      # too soon
    assert throttle.should_send(30.0, 0.06)
    assert throttle.should_send(0.0, 0.061)          # release goes at once


def test_wrench_converter_rotates_and_tares():
    # Sensor z points along the gripper's x (toward the receiver), sensor x along gripper y.
    rotation = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    conv = core.WrenchConverter(rotation, tare_samples=2)
    assert conv.convert((1.0, 0.0, 0.0), (0, 0, 0)) is None
    assert conv.convert((3.0, 0.0, 0.0), (0, 0, 0)) is None   # bias: gripper y = 2 N
    force, _ = conv.convert((2.0 + 1.962, 0.0, 5.0), (0, 0, 0))
    assert force == pytest.approx([5.0, 1.962, 0.0])
    assert conv.convert((float("nan"), 0, 0), (0, 0, 0)) is None


def test_optical_estimator_velocity_and_acceleration():
    est = core.OpticalEstimator([[1.0, 0.0], [0.0, 1.0]], counts_per_m=10000.0)
    s1 = est.to_gripper(0, 10, 0.01, quality=50, min_quality=1)      # 1 mm in 10 ms
    f1 = est.combine([s1])
    assert f1["velocity_m_s"] == pytest.approx((0.0, 0.1)) and f1["accel_y_m_s2"] == 0.0
    f2 = est.combine([est.to_gripper(0, 10, 0.005, 50, 1), est.to_gripper(0, 20, 0.005, 50, 1)])
    assert f2["displacement_counts"] == (0, 30) and f2["dt_s"] == pytest.approx(0.01)
    assert f2["velocity_m_s"][1] == pytest.approx(0.3)
    assert f2["accel_y_m_s2"] == pytest.approx((0.3 - 0.1) / 0.01)
    lost = est.combine([est.to_gripper(0, 5, 0.01, quality=0, min_quality=1)])
    assert lost["surface_valid"] is False and lost["displacement_counts"] == (0, 0) and lost["accel_y_m_s2"] == 0.0
    assert est.combine([]) is None


def test_plugin_key_is_hex_type_md5_and_topic():
    key = topic_key("/robot/joint_states", "sensor_msgs/JointState")
    assert key == ("73656e736f725f6d7367732f4a6f696e745374617465/3066dcd76a6cfaef579bd0f34173e9fd/"
                   "robot/joint_states")
    assert bytes.fromhex(key.split("/")[0]) == b"sensor_msgs/JointState"
    assert topic_key("/robot/state", "baxter_core_msgs/AssemblyState", "plugin", "lab1").split("/")[2:] == \
        ["lab1", "robot", "state"]
    assert topic_key("/robot/state", "baxter_core_msgs/AssemblyState", "plain", "ros1") == "ros1/robot/state"
    with pytest.raises(BaxterConfigError):
        topic_key("/robot/*", "std_msgs/Bool")


def test_config_rejects_bad_values_with_the_key():
    with pytest.raises(BaxterConfigError, match="ft_rotation"):
        parse_baxter_config({"ft_rotation": [[1, 0, 0], [0, 1, 0], [0, 1, 0]]})
    with pytest.raises(BaxterConfigError, match="joint_states"):
        parse_baxter_config({"topics": {"joint_states": "no slash"}})
    with pytest.raises(BaxterConfigError, match="unknown|Object contains"):
        parse_baxter_config({"speed": 3})


def test_describe_names_type_md5_and_key():
    from services.bridge.baxter.messages import Bool

    line = core.describe("k/enable", Bool(True), Bool(True).to_bytes())
    assert line.startswith("std_msgs/Bool [8b94c1b53db61fb6aed406028ad6332a] 1 B on k/enable: data=True | 01")
