"""The simulated Kinect service as a real process: the test plays the bridge (joint state and
sim truth) and checks what the camera publishes."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from robot_sim.kinect.receiver import BodySize, ReceiverBody
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration

BODY = ReceiverBody(BodySize(1.75, "standing"))


def _put_joint_state(pub) -> None:
    pub.put(names=list(RIGHT_ARM_JOINTS), position_rad=list(RIGHT_ARM_HOME_RAD),
            velocity_rad_s=[0.0] * 7, effort_nm=[0.0] * 7)


def _put_truth(pub, hand_m: np.ndarray, object_m: np.ndarray) -> None:
    pub.put(object_position_m=tuple(object_m), receiver_hand_position_m=tuple(hand_m), held_by="table")


def _hand_after(truth_sub, since_s: float, timeout_s: float = 5.0) -> np.ndarray:
    """The Kinect's true hand from the first `sim/kinect_truth` received after `since_s`
    plus two frames (the service renders with the latest input at its next frame)."""
    assert wait_until(lambda: truth_sub.latest() is not None and truth_sub.latest().rx_monotonic > since_s + 0.07,
                      timeout_s)
    return np.array(truth_sub.latest().msg.hand_position_m)


def test_kinect_renders_only_with_a_joint_state_at_30_hz_and_follows_the_scene(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.sim_kinect", profile, ["--scene", "handover"]) as kinect:
        wait_alive(router, profile, {"kinect"}, timeout_s=30)
        node = make_node()
        skeletons = node.subscribe(topics.SKELETON, queue_size=1000)
        depths = node.subscribe(topics.DEPTH, queue_size=1000)
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=1000)
        joint_pub = node.publisher(topics.JOINT_STATE)
        truth_pub = node.publisher(topics.SIM_TRUTH)
        # No joint state yet: the camera renders nothing.
        time.sleep(1.0)
        assert skeletons.latest() is None and depths.latest() is None and kinect_truth.latest() is None

        _put_joint_state(joint_pub)  # once: a stale joint state is fine
        assert wait_until(lambda: kinect_truth.latest() is not None, 10)
        # Without sim/truth yet, the hand is at rest.
        np.testing.assert_allclose(kinect_truth.latest().msg.hand_position_m, BODY.rest_hand_m, atol=1e-6)
        skeletons.drain()
        depths.drain()
        time.sleep(2.0)
        n_skel, n_depth = len(skeletons.drain()), len(depths.drain())
        assert 40 <= n_skel <= 70, n_skel  # ~30 Hz
        assert abs(n_depth - n_skel) <= 2
        depth = depths.latest().msg
        image = np.frombuffer(depth.depth_mm, dtype="<u2").reshape(depth.height, depth.width)
        assert (image > 0).mean() > 0.5  # floor, table, body: most pixels have a reading

        # The scene drives the receiver's hand: the rendered body's hand is where the scene
        # says (as far as the arm reaches), at two different places.
        obj = np.array([0.62, -0.26, 0.05])
        shoulder = BODY.joints(BODY.rest_hand_m)["right_shoulder"]
        for offset in (np.array([-0.35, 0.0, -0.25]), np.array([-0.45, 0.05, -0.05])):
            wanted = shoulder + offset
            t_sent = time.monotonic()
            _put_truth(truth_pub, wanted, obj)
            hand = _hand_after(kinect_truth, t_sent)
            expected = BODY.joints(wanted)["right_hand"]
            np.testing.assert_allclose(hand, expected, atol=1e-6)
            assert np.linalg.norm(expected - BODY.rest_hand_m) > 0.2  # a real move, not the rest pose
        torso = np.array(kinect_truth.latest().msg.torso_position_m)
        np.testing.assert_allclose(torso, BODY.joints(BODY.rest_hand_m)["torso"], atol=1e-6)
        assert kinect.proc.poll() is None


def test_kinect_without_scene_ignores_sim_truth_and_survives_odd_joint_states(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.sim_kinect", profile, ["--scene", "none"]) as kinect:
        wait_alive(router, profile, {"kinect"}, timeout_s=30)
        node = make_node()
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=1000)
        joint_pub = node.publisher(topics.JOINT_STATE)
        truth_pub = node.publisher(topics.SIM_TRUTH)
        # A joint state without the right arm's joints is skipped, not rendered.
        joint_pub.put(names=["left_s0", "left_s1"], position_rad=[0.0, 0.0], velocity_rad_s=[0.0, 0.0])
        time.sleep(0.5)
        assert kinect_truth.latest() is None
        # Joints in another order are mapped by name.
        order = list(reversed(range(7)))
        joint_pub.put(names=[RIGHT_ARM_JOINTS[i] for i in order],
                      position_rad=[RIGHT_ARM_HOME_RAD[i] for i in order], velocity_rad_s=[0.0] * 7)
        assert wait_until(lambda: kinect_truth.latest() is not None, 10)
        t_sent = time.monotonic()
        _put_truth(truth_pub, BODY.rest_hand_m + np.array([-0.3, 0.0, 0.3]), np.array([0.6, -0.26, 0.05]))
        hand = _hand_after(kinect_truth, t_sent)
        np.testing.assert_allclose(hand, BODY.rest_hand_m, atol=1e-6)  # its own (resting) hand
        assert kinect.proc.poll() is None
    assert "frame skipped" in kinect.log_text()
