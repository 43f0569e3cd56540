"""The bridge with the Baxter backend against the fake Baxter, both real processes on a
loopback router: joint commands from the bus move the fake arm (seen in the fake's own ROS 1
joint states), joint state comes back on the bus, the bridge holds on time-out, refuses a
disabled robot, enables it when asked, and sends nothing in a dry run."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import JointCommand, JointState
from services.runtime import ServiceNode
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.testing import BusRouter, ServiceProcess, wait_alive, wait_until

PROFILE = """
[bus]
endpoint = "tcp/127.0.0.1:{port}"
prefix = "handover/v1"
[services.fake_baxter]
module = "services.bridge.baxter.fake"
[services.fake_baxter.config]
object_mass_kg = 0.5
[services.bridge]
module = "services.bridge.baxter"
[services.bridge.config]
backend = "baxter"
command_timeout_s = 0.2
[services.bridge.config.baxter]
startup_timeout_s = 8.0
gripper_min_interval_s = 0.0
"""


@pytest.fixture
def bus(tmp_path):
    path = tmp_path / "baxter_fake_test.toml"
    path.write_text(PROFILE.format(port=free_tcp_port()))
    profile = load_profile_file(path)
    with BusRouter(profile) as router:
        yield profile, router


def _ros_joint_states(node: ServiceNode) -> list[JointState]:
    """Raw ROS 1 joint states of the fake (decoded here), arm messages only."""
    received: list[JointState] = []
    key = topic_key("/robot/joint_states", "sensor_msgs/JointState")

    def on_sample(sample):
        msg = JointState.from_bytes(sample.payload.to_bytes())
        if "right_s0" in msg.name:
            received.append(msg)

    node._keep = node.session.declare_subscriber(key, on_sample)  # type: ignore[attr-defined]
    return received


def _right_s0(msg: JointState) -> float:
    return msg.position[msg.name.index("right_s0")]


def test_commands_move_the_fake_arm_and_the_bridge_holds_on_timeout(bus):
    profile, router = bus
    fake = ServiceProcess("services.bridge.baxter.fake", profile, name="fake").start()
    bridge = ServiceProcess("services.bridge.baxter", profile, name="bridge").start()
    node = ServiceNode("tester", profile, install_signal_handlers=False)
    try:
        node.open()
        state = node.subscribe(topics.JOINT_STATE)
        wrench = node.subscribe(topics.WRIST_WRENCH)
        ros_states = _ros_joint_states(node)
        wait_alive(router, profile, {"bridge", "fake_baxter"}, 40.0)
        assert wait_until(lambda: state.latest() is not None, 10.0), bridge.log_text()
        first = state.latest().msg
        assert first.backend == "baxter" and tuple(first.names) == RIGHT_ARM_JOINTS
        assert first.position_rad == pytest.approx(RIGHT_ARM_HOME_RAD, abs=1e-9)

        pub = node.publisher(topics.JOINT_COMMAND)
        start = np.array(first.position_rad)
        goal = start.copy()
        goal[0] += 0.3
        for i in range(101):                      # 1 s ramp at 100 Hz, then the goal
            target = start + (goal - start) * min(1.0, i / 80)
            pub.put(names=list(RIGHT_ARM_JOINTS), position_rad=target.tolist())
            time.sleep(0.01)
        assert wait_until(lambda: abs(state.latest().msg.position_rad[0] - goal[0]) < 0.01, 2.0)
        # The fake's own ROS joint states moved the same way (independent of the bridge).
        assert _right_s0(ros_states[-1]) == pytest.approx(goal[0], abs=0.01)
        assert state.latest().msg.position_rad[1:] == pytest.approx(start[1:].tolist(), abs=1e-6)

        # No more commands: holding within the time-out, and the arm stays where it is.
        assert wait_until(lambda: state.latest().msg.holding, 1.0)
        held = _right_s0(ros_states[-1])
        time.sleep(0.5)
        assert _right_s0(ros_states[-1]) == pytest.approx(held, abs=1e-4)

        # An out-of-limit command is rejected by the bridge: the arm does not move.
        pub.put(names=["right_s0"], position_rad=[5.0])
        time.sleep(0.3)
        assert _right_s0(ros_states[-1]) == pytest.approx(held, abs=1e-4)

        # Gripper: a close command makes the fake feel the object's weight (0.5 kg, y down).
        grip = node.publisher(topics.GRIPPER_COMMAND)
        grip.put(grip_force_n=35.0)
        assert wait_until(lambda: wrench.latest() is not None
                          and abs(wrench.latest().msg.force_n[1] - 0.5 * 9.81) < 1e-6, 3.0)
        grip.put(grip_force_n=0.0)
        assert wait_until(lambda: abs(wrench.latest().msg.force_n[1]) < 1e-9, 3.0)
    finally:
        node.close()
        bridge_code = bridge.stop()
        fake.stop()
    assert bridge_code == 0, bridge.log_text()
    assert "sent_gripper_command=2" in bridge.log_text()


def test_refuses_to_start_on_a_disabled_robot(bus):
    profile, router = bus
    fake = ServiceProcess("services.bridge.baxter.fake", profile, args=["--disabled"], name="fake").start()
    bridge = ServiceProcess("services.bridge.baxter", profile, name="bridge")
    try:
        wait_alive(router, profile, {"fake_baxter"}, 30.0)
        bridge.start()
        assert bridge.proc.wait(30.0) == 1
        text = bridge.log_text()
        assert "refusing to start: the robot is not enabled" in text
        assert "bridge running" not in text
    finally:
        bridge.stop()
        fake.stop()


def test_enable_on_start_enables_the_robot(bus):
    profile, router = bus
    fake = ServiceProcess("services.bridge.baxter.fake", profile, args=["--disabled"], name="fake").start()
    bridge = ServiceProcess("services.bridge.baxter", profile, args=["--enable"], name="bridge")
    node = ServiceNode("tester", profile, install_signal_handlers=False)
    try:
        node.open()
        wait_alive(router, profile, {"fake_baxter"}, 30.0)
        bridge.start()
        wait_alive(router, profile, {"bridge"}, 30.0)
        assert "fake baxter enabled" in fake.log_text()
    finally:
        node.close()
        bridge.stop()
        fake.stop()


def test_dry_run_prints_commands_and_sends_nothing(bus):
    profile, router = bus
    fake = ServiceProcess("services.bridge.baxter.fake", profile, name="fake").start()
    bridge = ServiceProcess("services.bridge.baxter", profile, args=["--dry-run"], name="bridge")
    node = ServiceNode("tester", profile, install_signal_handlers=False)
    try:
        node.open()
        ros_states = _ros_joint_states(node)
        seen_commands: list[bytes] = []
        cmd_key = topic_key("/robot/limb/right/joint_command", "baxter_core_msgs/JointCommand")
        node._keep2 = node.session.declare_subscriber(  # type: ignore[attr-defined]
            cmd_key, lambda s: seen_commands.append(s.payload.to_bytes()))
        wait_alive(router, profile, {"fake_baxter"}, 30.0)
        bridge.start()
        wait_alive(router, profile, {"bridge"}, 30.0)
        pub = node.publisher(topics.JOINT_COMMAND)
        target = list(RIGHT_ARM_HOME_RAD)
        target[0] += 0.1
        for _ in range(50):
            pub.put(names=list(RIGHT_ARM_JOINTS), position_rad=target)
            time.sleep(0.01)
        time.sleep(0.3)
        assert seen_commands == []                                  # nothing on the robot's key
        assert _right_s0(ros_states[-1]) == pytest.approx(RIGHT_ARM_HOME_RAD[0], abs=1e-9)
    finally:
        node.close()
        code = bridge.stop()
        fake.stop()
    assert code == 0, bridge.log_text()
    lines = [ln for ln in bridge.log_text().splitlines() if ln.startswith("[dry-run] baxter_core_msgs/JointCommand")]
    assert len(lines) >= 40
    assert "[19bfec8434dd568ab3c633d187c36f2e]" in lines[0] and "mode=1" in lines[0]
    sent = [ln for ln in lines if "0.1000" in ln]
    assert sent, lines[:3]
    expected = JointCommand(mode=1, command=tuple(target), names=RIGHT_ARM_JOINTS).to_bytes()
    assert any(ln.endswith(expected[:48].hex() + "…") for ln in sent)
    assert "[dry-run] std_msgs/Float64 [fdb28210bfa9d7c91146260178d9a584] 8 B" in bridge.log_text()
