"""The full handover through the Baxter hardware backend, against the fake Baxter.

``handover-up --profile baxter_fake`` runs as a real subprocess (its own router on a free
loopback port, nine processes: recorder, fake Baxter, bridge with the Baxter backend, motion,
gripper, planner, tracker, supervisor). A taking receiver gets the object. Checked from
outside the stack, on the bus:

- the launcher exits 0 and reports the episode RELEASED;
- the path really is the hardware one: the bridge's joint states say ``backend=baxter``, the
  arm and gripper commands cross the bus as ROS 1 ``JointCommand`` / ``EndEffectorCommand``
  bytes on zenoh-bridge-ros1's keys (decoded here), the gripper closed and then opened;
- the fake plays the Kinect under ROS 1 (fake OpenNI): openni_tracker's ``/tf`` joint frames
  (the receiver, user 1, and a bystander, user 2) and the depth image cross the bus as ROS 1
  ``TFMessage`` / ``Image`` bytes in the camera's frame (decoded here; not the base frame: the
  camera's pose is not the identity); the tracker (``sensor = "ros1"``) turns them into `base`
  with the profile's calibration, publishes the skeleton of the receiver (user 1) and tracks
  the receiver's torso within 0.1 m of the rendered body's;
- sim truth: the object left the table, was in the gripper, ends in the receiver's hand
  (within a few cm of the true hand) and was never dropped.
"""

from __future__ import annotations

import subprocess
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from bus_schema import topics
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import EndEffectorCommand, JointCommand
from services.bridge.baxter.core import parse_gripper_args
from services.launcher.logins import OBSERVER, login_profile
from services.tracker.ros1.calibration import load_calibration
from services.tracker.ros1.messages import Image, TFMessage
from services.runtime import ServiceNode
from services.runtime.testing import free_tcp_port, kill_tree, loopback_profile
from tests.faults.matrix import stopped_before_the_fault

#: The whole run (start-up ≈ 10–20 s on a loaded 2-core machine, episode ≈ 7 s, shutdown ≈ 3 s).
RUN_TIMEOUT_S = 120.0
#: The observer's connect time-out and the kill wait, s, each run.
CONNECT_TIMEOUT_S = 30.0
KILL_WAIT_S = 10.0

# Two runs at most (the second only after a stop on a starved service), each within its limits.
pytestmark = [pytest.mark.integration,
              pytest.mark.timeout(int(2 * (RUN_TIMEOUT_S + CONNECT_TIMEOUT_S + KILL_WAIT_S) + 20))]
#: The object counts as in the receiver's hand within this distance of the true hand, m.
IN_HAND_M = 0.06


class _RosTap:
    """Decodes the Baxter backend's ROS 1 command bytes and the fake OpenNI camera's ``/tf`` and
    depth image bytes seen on the bus (Zenoh thread)."""

    def __init__(self, session) -> None:
        self.joint_commands: list[JointCommand] = []
        self.gripper_commands: list[EndEffectorCommand] = []
        self.tf: list[TFMessage] = []
        self.images: list[Image] = []
        self.bad: list[str] = []
        self._lock = threading.Lock()
        self._subs = [
            session.declare_subscriber(topic_key("/robot/limb/right/joint_command", JointCommand.TYPE),
                                       self._on(JointCommand, self.joint_commands)),
            session.declare_subscriber(topic_key("/robot/end_effector/right_gripper/command",
                                                 EndEffectorCommand.TYPE),
                                       self._on(EndEffectorCommand, self.gripper_commands)),
            session.declare_subscriber(topic_key("/tf", TFMessage.TYPE), self._on(TFMessage, self.tf)),
            session.declare_subscriber(topic_key("/camera/depth/image_raw", Image.TYPE), self._on(Image, self.images)),
        ]

    def _on(self, cls, into):
        def on_sample(sample) -> None:
            try:
                msg = cls.from_bytes(sample.payload.to_bytes())
            except Exception as exc:  # noqa: BLE001 - a Zenoh callback: recorded, asserted on in the test
                self.bad.append(repr(exc))
                return
            with self._lock:
                into.append(msg)
        return on_sample

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()


@dataclass
class _BaxterRun:
    """What one ``handover-up --profile baxter_fake`` run put on the bus and printed."""

    returncode: int
    out: str
    truths: list
    joint_states: list
    skeleton_sources: set
    kinect_truths: list
    skeletons: list
    humans: list
    tap: _RosTap
    #: What `stopped_before_the_fault` reads besides the exit line: no faults in this test.
    injections: tuple = ()
    phases_missed: tuple = ()

    @property
    def exit_line(self) -> str:
        exits = [line for line in self.out.splitlines() if line.startswith("[launcher] exit ")]
        return exits[-1] if exits else ""


def _run_stack(tmp_path, run_id: str) -> _BaxterRun:
    port = free_tcp_port()
    cmd = [sys.executable, "-m", "services.launcher", "--profile", "baxter_fake", "--port", str(port),
           "--recording-dir", str(tmp_path), "--run-id", run_id]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    node = tap = None
    try:
        profile = login_profile(loopback_profile(port, "baxter_fake"), tmp_path, run_id, OBSERVER,
                                timeout_s=CONNECT_TIMEOUT_S)  # the run's own logins
        node = ServiceNode(OBSERVER, profile, install_signal_handlers=False, connect_timeout_s=CONNECT_TIMEOUT_S)
        node.open()
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=100_000)
        states = node.subscribe(topics.JOINT_STATE, queue_size=100_000)
        skeletons = node.subscribe(topics.SKELETON, queue_size=10_000)
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=10_000)
        humans = node.subscribe(topics.HUMAN, queue_size=10_000)
        tap = _RosTap(node.session)
        try:
            out, _ = proc.communicate(timeout=RUN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            kill_tree(proc, KILL_WAIT_S)
            out, _ = proc.communicate()
            pytest.fail(f"handover-up did not finish in {RUN_TIMEOUT_S:.0f} s:\n{out[-6000:]}")
        skeleton_msgs = [rx.msg for rx in skeletons.drain()]
        return _BaxterRun(proc.returncode, out, [rx.msg for rx in truth.drain()],
                          [rx.msg for rx in states.drain()], {m.source for m in skeleton_msgs},
                          [rx.msg for rx in kinect_truth.drain()], skeleton_msgs,
                          [rx.msg for rx in humans.drain()], tap)
    finally:
        if tap is not None:
            tap.close()
        if node is not None:
            node.close()
        if proc.poll() is None:
            kill_tree(proc, KILL_WAIT_S)


def test_full_handover_through_the_baxter_backend_and_the_fake_robot(tmp_path):
    run = _run_stack(tmp_path, "baxter")
    (tmp_path / "baxter.log").write_text(run.out)
    if (starved := stopped_before_the_fault(run, [])) is not None:
        # No fault is injected here: a service that looked silent was a live process starved of
        # CPU on a loaded machine (its own log says so), not the behaviour under test. Once more,
        # printed (the first run's output is kept); a second such stop fails below.
        print(f"stack stopped with no fault injected ({starved}); running it once more; "
              f"first run's output: {tmp_path / 'baxter.log'}")
        run = _run_stack(tmp_path, "baxter-again")
    out, tap = run.out, run.tap
    truths, joint_states = run.truths, run.joint_states
    kinect_truths = run.kinect_truths

    # On failure: the launcher's lines and those of the robot side (not the recorder's chatter).
    launcher = "\n".join(line for line in out.splitlines()
                         if line.startswith(("[launcher]", "[bridge]", "[fake_baxter]", "[supervisor]"))
                         and "overran" not in line)
    assert run.returncode == 0, launcher[-4000:]
    assert "episode 1: RELEASED: released to the receiver" in out, launcher[-4000:]
    assert "summary: 1 episode(s): released; object never dropped" in out
    assert "object (sim truth): in the receiver's hand; never dropped" in out

    # The hardware path: the bridge ran the Baxter backend, commands went out as ROS 1 bytes.
    assert joint_states and {m.backend for m in joint_states} == {"baxter"}
    assert {m.source for m in joint_states} == {"bridge"}
    assert not tap.bad, tap.bad[:3]
    assert len(tap.joint_commands) > 500, len(tap.joint_commands)  # 100 Hz over a ≥ 7 s episode
    assert all(c.mode == JointCommand.POSITION_MODE and len(c.command) == 7 for c in tap.joint_commands)
    s0 = np.array([c.command[c.names.index("right_s0")] for c in tap.joint_commands])
    assert np.ptp(s0) > 0.1, f"right_s0 commands span only {np.ptp(s0):.3f} rad"
    grips = [parse_gripper_args(c.args) for c in tap.gripper_commands]  # (position %, force %)
    closed = [i for i, (position, force) in enumerate(grips) if position < 50 and force > 0]
    assert closed, grips
    assert any(position > 50 and force == 0 for position, force in grips[closed[0]:]), \
        f"the gripper never opened after closing: {grips}"

    # The fake stands in for the Kinect under ROS 1; the tracker reads it through that path.
    _check_the_ros1_kinect_path(run)

    # Sim truth, independently of the launcher's report.
    assert len(truths) > 500
    assert {m.source for m in truths} == {"fake_baxter"}
    assert not any(m.dropped for m in truths), "the object was dropped"
    holders = [m.held_by for m in truths]
    assert "gripper" in holders, sorted(set(holders))
    first_gripper = holders.index("gripper")
    assert "table" in holders[:first_gripper], "the object did not start on the table"
    assert "receiver" in holders[first_gripper:]
    last = truths[-1]
    assert last.held_by == "receiver"
    start = np.array(truths[0].object_position_m)
    end = np.array(last.object_position_m)
    hand = np.array(last.receiver_hand_position_m)
    assert np.linalg.norm(end - start) > 0.2, "the object never left the table"
    assert np.linalg.norm(end - hand) < IN_HAND_M, f"object {end} is {np.linalg.norm(end - hand):.3f} m from the hand"
    # The receiver's hand in the scene and the body the Kinect rendered are the same hand.
    assert kinect_truths and {m.source for m in kinect_truths} == {"fake_baxter"}
    assert np.linalg.norm(np.array(kinect_truths[-1].hand_position_m) - hand) < 0.05


def _check_the_ros1_kinect_path(run: _BaxterRun) -> None:
    """openni_tracker's /tf and the depth image crossed the bus as ROS 1 bytes in the camera's
    frame; the tracker converted them with the calibration and chose the receiver."""
    tap = run.tap
    assert run.skeleton_sources == {"tracker"}
    joints = [tf for msg in tap.tf for tf in msg.transforms]
    assert len(joints) > 15 * 2 * 30 * 5, len(joints)  # 2 users, 30 Hz, a run of more than 5 s
    assert {tf.header.frame_id for tf in joints} == {"openni_depth_frame"}
    assert {tf.child_frame_id.rsplit("_", 1)[1] for tf in joints} == {"1", "2"}
    assert len(tap.images) > 30 * 5 and {(m.encoding, m.width, m.height) for m in tap.images} == {("16UC1", 320, 240)}
    tracked = [m for m in run.skeletons if m.tracked]
    assert tracked and {m.user_id for m in tracked} == {1}  # the receiver, never the bystander
    # The torso as sent (camera frame) is far from the true torso; through the profile's
    # calibration it lands on it (within the simulated tracker's joint noise).
    pose = load_calibration(Path(__file__).resolve().parents[2] / "deploy" / "kinect_calibration_fake.toml")
    true_torso = np.array(run.kinect_truths[-1].torso_position_m)
    sent = np.array([[t.x, t.y, t.z] for tf in joints if tf.child_frame_id == "torso_1"
                     for t in [tf.transform.translation]])
    assert np.median(np.linalg.norm(sent - true_torso, axis=1)) > 0.3  # read as base: 0.4 m off
    assert np.median(np.linalg.norm(pose.to_base(sent) - true_torso, axis=1)) < 0.1
    human = [np.array(m.torso_position_m) for m in run.humans if m.tracked]
    assert len(human) > 30 * 5
    assert np.median(np.linalg.norm(np.array(human) - true_torso, axis=1)) < 0.1
