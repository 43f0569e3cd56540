"""Bridge (sim backend) + simulated Kinect → tracker as real processes: the human and the
object come out, and the Kinect's truth matches what the tracker reports. The Kinect either
as its own service (`services.sim_kinect`, the tracker's ``sensor = "bus"``) or rendered in
the tracker's process (``sensor = "sim"``, the default profile's)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from handover_model import scene
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration


def test_bridge_and_kinect_feed_the_tracker(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge, \
            ServiceProcess("services.sim_kinect", profile) as kinect, \
            ServiceProcess("services.tracker", profile, ["--sensor", "bus"]) as tracker:
        wait_alive(router, profile, {"bridge", "kinect", "tracker"}, timeout_s=30)
        node = make_node()
        skeletons = node.subscribe(topics.SKELETON, queue_size=1000)
        states = node.subscribe(topics.JOINT_STATE, queue_size=1000)
        humans = node.subscribe(topics.HUMAN, queue_size=1000)
        objects = node.subscribe(topics.OBJECT, queue_size=1000)
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=1000)
        sim_truth = node.subscribe(topics.SIM_TRUTH, queue_size=1000)
        assert wait_until(lambda: humans.latest() is not None and humans.latest().msg.tracked, 15)
        skeletons.drain()
        states.drain()
        frames = kinect_truth.drain()
        time.sleep(2.0)
        skel_window, n_state = skeletons.drain(), len(states.drain())
        assert 40 <= len(skel_window) <= 70, len(skel_window)  # ~30 Hz
        assert 160 <= n_state <= 220, n_state  # the servo loop keeps ~100 Hz
        assert {rx.msg.source for rx in skel_window} == {"kinect"}  # the bridge no longer renders
        frames = kinect_truth.drain()
        # The skeleton's right hand is the Kinect's true hand plus its error model (50-100 mm
        # jitter, correlated over ~0.1 s): averaged over 2 s of a resting hand, a few cm.
        hand_true = np.mean([rx.msg.hand_position_m for rx in frames], axis=0)
        hand_skel = np.mean([next(j.position_m for j in rx.msg.joints if j.name == "right_hand")
                             for rx in skel_window if rx.msg.tracked], axis=0)
        assert np.linalg.norm(hand_skel - hand_true) < 0.06, (hand_skel, hand_true)
        # One receiver: the body the Kinect renders holds its hand where the bridge's scene has it.
        np.testing.assert_allclose(frames[-1].msg.hand_position_m, sim_truth.latest().msg.receiver_hand_position_m,
                                   atol=0.01)
        human = humans.latest().msg
        assert human.posture == "standing"
        assert human.height_m == pytest.approx(1.75, abs=0.1)
        hand_est = np.array(human.hand_position_m)
        assert np.linalg.norm(hand_est - np.array(frames[-1].msg.hand_position_m)) < 0.25  # tracker's budget
        torso = np.array(frames[-1].msg.torso_position_m)
        assert abs(torso[0] - scene.RECEIVER_TORSO_BASE_XY_M[0]) < 0.3
        assert wait_until(lambda: objects.latest() is not None and objects.latest().msg.found, 10)
        found = np.array(objects.latest().msg.position_m)
        assert np.linalg.norm(found[:2] - scene.OBJECT_PICK_BASE_M[:2]) < 0.05
        assert bridge.proc.poll() is None and kinect.proc.poll() is None and tracker.proc.poll() is None


def test_sitting_receiver_without_contact_plant(bus, make_node):
    """Arm-only bridge, Kinect without scene input, sitting receiver: the tracker sees a
    sitting person and the Kinect's truth hand is its own resting hand."""
    profile, router = bus
    with ServiceProcess("services.bridge", profile, ["--no-contact", "--posture", "sitting"]), \
            ServiceProcess("services.sim_kinect", profile, ["--scene", "none", "--posture", "sitting"]), \
            ServiceProcess("services.tracker", profile, ["--sensor", "bus"]):
        wait_alive(router, profile, {"bridge", "kinect", "tracker"}, timeout_s=30)
        node = make_node()
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=1000)
        humans = node.subscribe(topics.HUMAN, queue_size=1000)
        sim_truth = node.subscribe(topics.SIM_TRUTH, queue_size=10)
        assert wait_until(lambda: humans.latest() is not None and humans.latest().msg.tracked, 15)
        assert wait_until(lambda: humans.latest().msg.posture == "sitting", 10)
        from robot_sim.kinect.receiver import BodySize, ReceiverBody

        rest = ReceiverBody(BodySize(1.75, "sitting")).rest_hand_m
        assert wait_until(lambda: kinect_truth.latest() is not None, 5)
        np.testing.assert_allclose(kinect_truth.latest().msg.hand_position_m, rest, atol=1e-6)
        assert sim_truth.latest() is None  # no contact plant: nobody publishes sim/truth


def test_the_tracker_renders_the_simulated_kinect_itself(bus, make_node):
    """``sensor = "sim"``: no Kinect process; the tracker publishes the skeleton (~30 Hz) and
    the Kinect's truth, tracks the receiver and finds the object; the depth image stays in its
    process unless ``--publish-depth``."""
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge, \
            ServiceProcess("services.tracker", profile, ["--sensor", "sim"]) as tracker:
        wait_alive(router, profile, {"bridge", "tracker"}, timeout_s=30)
        node = make_node()
        skeletons = node.subscribe(topics.SKELETON, queue_size=1000)
        depths = node.subscribe(topics.DEPTH, queue_size=100)
        humans = node.subscribe(topics.HUMAN, queue_size=1000)
        objects = node.subscribe(topics.OBJECT, queue_size=1000)
        kinect_truth = node.subscribe(topics.KINECT_TRUTH, queue_size=1000)
        sim_truth = node.subscribe(topics.SIM_TRUTH, queue_size=1000)
        assert wait_until(lambda: humans.latest() is not None and humans.latest().msg.tracked, 20)
        skeletons.drain()
        kinect_truth.drain()
        time.sleep(2.0)
        skel_window, frames = skeletons.drain(), kinect_truth.drain()
        assert 40 <= len(skel_window) <= 70, len(skel_window)  # ~30 Hz
        assert {rx.msg.source for rx in skel_window} == {"tracker"}
        assert depths.drain() == []  # the image never crossed the bus
        np.testing.assert_allclose(frames[-1].msg.hand_position_m, sim_truth.latest().msg.receiver_hand_position_m,
                                   atol=0.01)  # one receiver: the bridge's scene drives the body
        human = humans.latest().msg
        assert human.height_m == pytest.approx(1.75, abs=0.1)
        assert np.linalg.norm(np.array(human.hand_position_m) - np.array(frames[-1].msg.hand_position_m)) < 0.25
        assert wait_until(lambda: objects.latest() is not None and objects.latest().msg.found, 10)
        found = np.array(objects.latest().msg.position_m)
        assert np.linalg.norm(found[:2] - scene.OBJECT_PICK_BASE_M[:2]) < 0.05
        assert bridge.proc.poll() is None and tracker.proc.poll() is None


def test_the_tracker_publishes_its_depth_image_when_asked(bus, make_node):
    profile, router = bus
    with ServiceProcess("services.bridge", profile), \
            ServiceProcess("services.tracker", profile, ["--sensor", "sim", "--publish-depth", "--posture", "sitting"]):
        wait_alive(router, profile, {"bridge", "tracker"}, timeout_s=30)
        node = make_node()
        depths = node.subscribe(topics.DEPTH, queue_size=100)
        assert wait_until(lambda: depths.latest() is not None, 20)
        depths.drain()
        time.sleep(1.0)
        window = depths.drain()
        assert 20 <= len(window) <= 40, len(window)  # ~30 Hz
        image = window[-1].msg
        assert image.source == "tracker" and (image.width, image.height) == (320, 240)
        assert len(image.depth_mm) == 2 * 320 * 240
