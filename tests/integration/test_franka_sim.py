"""The bridge with the Franka backend against franky-sim, real processes on loopback: the
simulated robot (`services.bridge.franka.sim`: MuJoCo physics behind libfranka's own network
protocol on a 127.x.y.z address), the bridge (`python -m services.bridge.franka`: franky /
libfranka inside), a Zenoh router, and for the lost robot the supervisor.

What the robot really did is read from the simulator's own state file, not from the bridge.

libfranka's ports (1337, 1338) are fixed: each test's robot gets a loopback address of its
own (`_free_robot_host`), so tests can run side by side (xdist) without sharing a robot.
"""

from __future__ import annotations

import json
import socket
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

from bus_schema import topics
from services.runtime import ServiceNode
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.testing import BusRouter, ServiceProcess, wait_alive, wait_until

pytest.importorskip("franky", reason="the Franka backend needs franky-control (pip install -e '.[test]')")
pytest.importorskip("franky_sim", reason="the Franka tests need franky-sim")
pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]

PROFILE = """
[bus]
endpoint = "tcp/127.0.0.1:{port}"
prefix = "handover/v1"
[services.franka_sim]
module = "services.bridge.franka.sim"
[services.franka_sim.config]
host = "{host}"
state_file = "{state}"
[services.bridge]
module = "services.bridge.franka"
[services.bridge.config]
backend = "franka"
command_timeout_s = 0.2
[services.bridge.config.franka]
host = "{host}"
model = "fr3"
realtime = "ignore"
relative_dynamics_factor = 0.5
{extra}
"""
#: The simulated robot is not a service on a real robot: its own loss is only reported, so
#: what stops the stack is the bridge losing the robot, as it would be on hardware.
SUPERVISOR = """
[services.supervisor]
module = "services.supervisor"
[services.supervisor.config]
watch = {franka_sim = "report", recorder = "report"}
"""
HOME = np.array([0.0, 0.0, 0.0, -1.57, 0.0, 1.57, 0.785])
NAMES = [f"fr3_joint{i}" for i in range(1, 8)]


def _free_robot_host() -> str:
    """A 127.0.0.x address whose libfranka ports (TCP 1337 and 1338) are free."""
    for x in range(20, 250):
        host = f"127.0.0.{x}"
        socks = []
        try:
            for port in (1337, 1338):
                s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                socks.append(s)
                s.bind((host, port))
            return host
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
    raise RuntimeError("no free loopback address for a simulated robot")


class _Rig:
    def __init__(self, tmp_path: Path, extra: str = "", supervisor: bool = False) -> None:
        self.state_path = tmp_path / "franka_state.json"
        path = tmp_path / "franka_test.toml"
        path.write_text(PROFILE.format(port=free_tcp_port(), host=_free_robot_host(), state=self.state_path,
                                       extra=extra) + (SUPERVISOR if supervisor else ""))
        self.profile = load_profile_file(path)

    def sim_q(self) -> np.ndarray:
        return np.array(json.loads(self.state_path.read_text())["q_rad"])

    def hand_width_m(self) -> float:
        return float(json.loads(self.state_path.read_text())["hand_width_m"])


def _start(rig: _Rig, router, bridge_args=()):
    sim = ServiceProcess("services.bridge.franka.sim", rig.profile, name="franka_sim").start()
    wait_alive(router, rig.profile, {"franka_sim"}, 60.0)
    assert wait_until(rig.state_path.exists, 10.0), sim.log_text()
    bridge = ServiceProcess("services.bridge.franka", rig.profile, args=list(bridge_args), name="bridge").start()
    node = ServiceNode("tester", rig.profile, install_signal_handlers=False)
    node.open()
    return sim, bridge, node


def _min_jerk_stream(pub, start: np.ndarray, goal: np.ndarray, duration_s: float, stop_at_s: float = np.inf):
    """Send a minimum-jerk trajectory start→goal at 100 Hz (position + velocity)."""
    t0 = time.monotonic()
    while True:
        t = time.monotonic() - t0
        if t > min(duration_s + 0.3, stop_at_s):
            return
        s = min(t / duration_s, 1.0)
        p = 10 * s**3 - 15 * s**4 + 6 * s**5
        dp = (30 * s**2 - 60 * s**3 + 30 * s**4) / duration_s if s < 1.0 else 0.0
        pub.put(names=NAMES, position_rad=(start + (goal - start) * p).tolist(),
                velocity_rad_s=((goal - start) * dp).tolist())
        time.sleep(0.01)


@pytest.fixture
def rig(tmp_path):
    return _Rig(tmp_path)


def test_follows_commands_holds_refuses_and_grips(rig):
    with BusRouter(rig.profile) as router:
        sim, bridge, node = _start(rig, router)
        try:
            state = node.subscribe(topics.JOINT_STATE)
            assert wait_until(lambda: state.latest() is not None, 30.0), bridge.log_text()
            first = state.latest().msg
            assert first.backend == "franka" and list(first.names) == NAMES
            # The simulated robot listens on its loopback address only (franky-sim's UDP loop
            # socket would bind every interface: `keep_on_loopback`).
            bound = {c.laddr.ip for c in psutil.Process(sim.pid).net_connections(kind="inet") if c.laddr}
            assert bound and all(ip.startswith("127.") for ip in bound), bound
            assert first.position_rad == pytest.approx(HOME.tolist(), abs=0.01)
            # 100 Hz on the bus
            state.drain()
            time.sleep(1.0)
            assert 80 <= len(state.drain()) <= 120

            pub = node.publisher(topics.JOINT_COMMAND)
            goal = HOME.copy()
            goal[0] += 0.4
            goal[3] -= 0.2
            _min_jerk_stream(pub, HOME, goal, 1.5)
            assert wait_until(lambda: np.max(np.abs(rig.sim_q() - goal)) < 0.02, 2.0), (rig.sim_q(), goal)
            assert state.latest().msg.position_rad == pytest.approx(goal.tolist(), abs=0.02)

            # No more commands: the bridge holds within its time-out and the arm stays put.
            assert wait_until(lambda: state.latest().msg.holding, 1.0)
            held = rig.sim_q()
            time.sleep(0.5)
            assert rig.sim_q() == pytest.approx(held.tolist(), abs=2e-3)

            # Refused: a target past a joint limit, and a jump of 0.5 rad in one command.
            beyond = held.copy()
            beyond[0] = 2.9                        # FR3 joint 1 limit 2.7437 rad
            jump = held.copy()
            jump[1] += 0.5
            for target in (beyond, jump):
                time.sleep(1.1)                    # one "rejected" line per second at most
                for _ in range(30):
                    pub.put(names=NAMES, position_rad=target.tolist())
                    time.sleep(0.01)
                assert state.latest().msg.holding
                assert rig.sim_q() == pytest.approx(held.tolist(), abs=2e-3)
            text = bridge.log_text()
            assert "outside its limits" in text and "send a trajectory, not a jump" in text

            # The Hand: a grip force closes it, 0 N opens it (franky-sim has no object to feel).
            grip = node.publisher(topics.GRIPPER_COMMAND)
            width0 = rig.hand_width_m()
            grip.put(grip_force_n=30.0)
            assert wait_until(lambda: rig.hand_width_m() < 0.005, 5.0), (width0, rig.hand_width_m())
            grip.put(grip_force_n=0.0)
            assert wait_until(lambda: rig.hand_width_m() > 0.075, 5.0), rig.hand_width_m()
        finally:
            node.close()
            code = bridge.stop()
            sim.stop()
    assert code == 0, bridge.log_text()
    assert "rejected" in bridge.log_text()


def test_protective_stop_stops_the_arm_at_once(rig):
    with BusRouter(rig.profile) as router:
        sim, bridge, node = _start(rig, router)
        try:
            state = node.subscribe(topics.JOINT_STATE)
            assert wait_until(lambda: state.latest() is not None, 30.0), bridge.log_text()
            pub = node.publisher(topics.JOINT_COMMAND)
            stop = node.publisher(topics.MOTION_STOP)
            goal = HOME.copy()
            goal[0] += 0.8
            _min_jerk_stream(pub, HOME, goal, 2.0, stop_at_s=1.0)     # mid-reach, about full speed
            moving = state.latest().msg
            assert max(abs(v) for v in moving.velocity_rad_s) > 0.3, moving
            stop.put(reason="test", protective=True)
            t_stop = time.monotonic()
            # Commands keep coming after the stop: the brake ignores them.
            for _ in range(50):
                pub.put(names=NAMES, position_rad=goal.tolist())
                time.sleep(0.01)
            q_at_stop_plus = rig.sim_q()
            time.sleep(0.3)
            assert rig.sim_q() == pytest.approx(q_at_stop_plus.tolist(), abs=2e-3)
            assert q_at_stop_plus[0] < goal[0] - 0.1                  # it did not go on to the goal
            assert abs(state.latest().msg.velocity_rad_s[0]) < 0.02
            assert time.monotonic() - t_stop < 2.0
        finally:
            node.close()
            code = bridge.stop()
            sim.stop()
    assert code == 0, bridge.log_text()
    assert "sent_brake=1" in bridge.log_text()


def test_lost_robot_mid_reach_stops_the_bridge_and_the_supervisor_reports_it(tmp_path):
    rig = _Rig(tmp_path, supervisor=True)
    with BusRouter(rig.profile) as router:
        sim, bridge, node = _start(rig, router)
        supervisor = ServiceProcess("services.supervisor", rig.profile, name="supervisor").start()
        try:
            state = node.subscribe(topics.JOINT_STATE)
            sup_state = node.subscribe(topics.SUPERVISOR_STATE, queue_size=1000)
            stops = node.subscribe(topics.MOTION_STOP, queue_size=100)
            wait_alive(router, rig.profile, {"bridge", "supervisor"}, 60.0)
            assert wait_until(lambda: state.latest() is not None, 30.0), bridge.log_text()
            pub = node.publisher(topics.JOINT_COMMAND)
            goal = HOME.copy()
            goal[0] += 0.8
            _min_jerk_stream(pub, HOME, goal, 2.0, stop_at_s=0.8)
            sim.proc.kill()                                           # the robot is gone mid-reach
            killed = time.monotonic()
            sim.proc.wait(5.0)
            assert bridge.proc.wait(10.0) == 1, bridge.log_text()
            lost_after_s = time.monotonic() - killed
            text = bridge.log_text()
            assert "lost the Franka" in text or "has not advanced" in text, text[-2000:]
            assert wait_until(lambda: any(rx.msg.protective for rx in stops.drain()), 5.0)
            assert wait_until(lambda: any("bridge" in rx.msg.reason and rx.msg.phase == "protective_stop"
                                          for rx in sup_state.drain()), 5.0)
            assert "service fault" in supervisor.log_text() and "service=bridge" in supervisor.log_text()
            assert lost_after_s < 5.0
        finally:
            node.close()
            bridge.stop()
            supervisor.stop()
            sim.stop()


def test_dry_run_reads_publishes_and_moves_nothing(rig):
    with BusRouter(rig.profile) as router:
        sim, bridge, node = _start(rig, router, bridge_args=["--dry-run"])
        try:
            state = node.subscribe(topics.JOINT_STATE)
            assert wait_until(lambda: state.latest() is not None, 30.0), bridge.log_text()
            before = rig.sim_q()
            width = rig.hand_width_m()
            pub = node.publisher(topics.JOINT_COMMAND)
            goal = HOME.copy()
            goal[0] += 0.08                  # within max_step_rad of the arm, which does not move
            _min_jerk_stream(pub, HOME, goal, 1.0)
            node.publisher(topics.GRIPPER_COMMAND).put(grip_force_n=30.0)
            time.sleep(0.5)
            assert rig.sim_q() == pytest.approx(before.tolist(), abs=1e-3)
            assert rig.hand_width_m() == pytest.approx(width, abs=1e-3)
            assert state.latest().msg.position_rad == pytest.approx(before.tolist(), abs=1e-3)
        finally:
            node.close()
            code = bridge.stop()
            sim.stop()
    assert code == 0, bridge.log_text()
    lines = [ln for ln in bridge.log_text().splitlines() if ln.startswith("[dry-run] JointVelocityMotion")]
    assert len(lines) >= 80
    assert any("fr3_joint1=+0." in ln and "fr3_joint1=+0.0000" not in ln for ln in lines)
    assert "[dry-run] Hand grasp force 30.0 N" in bridge.log_text()


def test_refuses_to_start_without_a_robot(tmp_path):
    rig = _Rig(tmp_path)
    with BusRouter(rig.profile):
        bridge = ServiceProcess("services.bridge.franka", rig.profile, name="bridge").start()
        try:
            assert bridge.proc.wait(30.0) == 1
            text = bridge.log_text()
            assert "cannot reach the Franka at 127.0.0." in text and "bridge running" not in text
        finally:
            bridge.stop()
