"""The fake Baxter with the handover scene, in process on a loopback bus: it plays the Kinect
driver (skeleton and depth of the scene's own receiver, and the Kinect's ground truth on
`sim/kinect_truth`), publishes sim truth, and resets the scene on a new supervisor episode
only."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from handover_model import scene as scene_layout
from services.bridge.baxter.config import parse_baxter_config
from services.bridge.baxter.fake import SERVICE_NAME, FakeBaxter, parse_fake_config
from services.bridge.handover_backend import HandoverSimBackend
from services.runtime.testing import wait_until

OBJECT_START_M = np.array(scene_layout.OBJECT_PICK_BASE_M, float)


@pytest.fixture
def fake(make_node):
    config = parse_fake_config({"contact": {"enabled": True, "scenario": "handover", "behaviour": "taking"},
                                "kinect": {"enabled": True, "posture": "standing"}})
    node = make_node(SERVICE_NAME)
    robot = FakeBaxter(node, config, parse_baxter_config({}))
    try:
        yield robot
    finally:
        robot.close()


def _run(robot: FakeBaxter, ticks: int) -> None:
    """Tick the fake `ticks` times at ≈ 100 Hz (its Kinect thread runs meanwhile)."""
    for _ in range(ticks):
        robot.tick(0.01)
        time.sleep(0.01)


def test_the_fake_plays_the_kinect_on_the_scenes_receiver(fake, make_node):
    observer = make_node("observer")
    skeletons = observer.subscribe(topics.SKELETON, queue_size=1000)
    depths = observer.subscribe(topics.DEPTH, queue_size=1000)
    truth = observer.subscribe(topics.SIM_TRUTH, queue_size=10_000)
    kinect_truth = observer.subscribe(topics.KINECT_TRUTH, queue_size=1000)
    assert isinstance(fake.physics, HandoverSimBackend)
    time.sleep(0.3)  # subscribers known to the router
    _run(fake, 50)  # one sim/truth per tick
    assert wait_until(lambda: skeletons.latest() is not None and depths.latest() is not None, 5.0)
    assert {rx.msg.source for rx in skeletons.drain()} == {SERVICE_NAME}
    truths: list = []
    assert wait_until(lambda: (truths.extend(rx.msg for rx in truth.drain()), len(truths) >= 50)[1], 5.0), len(truths)
    last = truths[-1]
    assert last.source == SERVICE_NAME and last.held_by == "table" and not last.dropped
    np.testing.assert_allclose(last.object_position_m, OBJECT_START_M, atol=1e-9)
    # The Kinect's body is the scene's receiver: its true right hand is the scene's hand.
    hand_m, _ = fake.physics.scene_snapshot()
    assert wait_until(lambda: kinect_truth.latest() is not None, 5.0)
    assert kinect_truth.latest().msg.source == SERVICE_NAME
    np.testing.assert_allclose(kinect_truth.latest().msg.hand_position_m, hand_m, atol=0.02)
    np.testing.assert_allclose(last.receiver_hand_position_m, hand_m, atol=1e-9)


def test_a_new_supervisor_episode_resets_the_scene(fake, make_node):
    supervisor = make_node("supervisor").publisher(topics.SUPERVISOR_STATE)
    time.sleep(0.3)
    scene = fake.physics.scene

    def announce(episode_id: int) -> None:
        supervisor.put(phase="pick", episode_id=episode_id, reason="", elapsed_s=0.0, grip_request="open")

    announce(1)
    assert wait_until(lambda: (fake.tick(0.01), fake.episode_id == 1)[1], 3.0)
    assert fake.scene_resets == 0  # the first episode seen is the scene as it is
    scene.object_m = OBJECT_START_M + np.array([0.0, 0.0, 0.3])  # as if lifted
    episodes_before = scene.episode
    announce(1)  # the same episode again: no reset
    _run(fake, 20)
    assert fake.scene_resets == 0
    np.testing.assert_allclose(scene.object_m, OBJECT_START_M + [0.0, 0.0, 0.3])
    announce(2)
    assert wait_until(lambda: (fake.tick(0.01), fake.scene_resets == 1)[1], 3.0)
    fake.tick(0.01)  # the reset happens in the physics step
    assert scene.episode == episodes_before + 1
    np.testing.assert_allclose(scene.object_m, OBJECT_START_M, atol=1e-9)
    assert scene.object_phase == "on_table"
