"""Bridge (sim Kinect) → tracker as real processes: the human and the object come out."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from robot_sim import scene
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration


def test_bridge_kinect_feeds_the_tracker(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.bridge", profile, ["--kinect"]) as bridge, \
            ServiceProcess("services.tracker", profile) as tracker:
        wait_alive(router, profile, {"bridge", "tracker"}, timeout_s=30)
        node = make_node()
        skeletons = node.subscribe(topics.SKELETON, queue_size=1000)
        states = node.subscribe(topics.JOINT_STATE, queue_size=1000)
        humans = node.subscribe(topics.HUMAN, queue_size=1000)
        objects = node.subscribe(topics.OBJECT, queue_size=1000)
        assert wait_until(lambda: humans.latest() is not None and humans.latest().msg.tracked, 10)
        skeletons.drain()
        states.drain()
        time.sleep(2.0)
        n_skel, n_state = len(skeletons.drain()), len(states.drain())
        assert 40 <= n_skel <= 70, n_skel  # ~30 Hz
        assert 160 <= n_state <= 220, n_state  # the servo loop keeps ~100 Hz beside the renderer
        human = humans.latest().msg
        assert human.posture == "standing"
        assert human.height_m == pytest.approx(1.75, abs=0.1)
        assert wait_until(lambda: objects.latest() is not None and objects.latest().msg.found, 10)
        found = np.array(objects.latest().msg.position_m)
        assert np.linalg.norm(found[:2] - scene.OBJECT_PICK_BASE_M[:2]) < 0.05
        assert bridge.proc.poll() is None and tracker.proc.poll() is None


@pytest.mark.parametrize("contact", [True, False])
def test_sim_truth_carries_the_kinect_receivers_hand(bus, make_node, contact):
    profile, router = bus
    args = ["--kinect"] + ([] if contact else ["--no-contact"])
    with ServiceProcess("services.bridge", profile, args), ServiceProcess("services.tracker", profile):
        wait_alive(router, profile, {"bridge", "tracker"}, timeout_s=30)
        node = make_node()
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=1000)
        humans = node.subscribe(topics.HUMAN, queue_size=1000)
        assert wait_until(lambda: truth.latest() is not None
                          and truth.latest().msg.kinect_hand_truth_m is not None, 10)
        assert wait_until(lambda: humans.latest() is not None and humans.latest().msg.tracked, 10)
        time.sleep(1.0)
        hand_true = np.array(truth.latest().msg.kinect_hand_truth_m)
        hand_est = np.array(humans.latest().msg.hand_position_m)
        # The tracker's hand is within the Kinect's error budget (jitter 50-100 mm, ~130 ms lag).
        assert np.linalg.norm(hand_true - hand_est) < 0.25
        torso = np.array(truth.latest().msg.kinect_torso_truth_m)
        assert abs(torso[0] - scene.RECEIVER_TORSO_BASE_XY_M[0]) < 0.3
