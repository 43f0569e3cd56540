"""`Ros1KinectInputs` on a real loopback bus: ROS 1 bytes on zenoh-bridge-ros1's keys in, the
receiver's skeleton in `base` and the depth frame into the tracker's pipeline and onto
`perception/skeleton`; malformed payloads counted and dropped; the loss of the skeleton
reported; late depth images dropped."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics as T
from bus_schema.messages import SKELETON_JOINTS
from handover_model.robot_geometry import ArmGeometry
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.messages import Header
from services.bridge.baxter.ros1 import Time
from services.runtime.testing import wait_until
from services.tracker.config import config_from_dict
from services.tracker.core import TrackerPipeline
from services.tracker.node import _Feeder
from services.tracker.ros1.calibration import parse_calibration
from services.tracker.ros1.config import Ros1KinectConfig
from services.tracker.ros1.messages import CameraInfo, Image, TFMessage
from services.tracker.ros1.source import Ros1KinectInputs
from tests.unit.tracker.test_ros1_skeleton import wire

#: Camera 1 m up, pitched 90 degrees down: camera (x, y, z) → base (0.2 + z, y, 1 - x).
POSE = parse_calibration({"position_m": [0.2, 0.0, 1.0], "rpy_deg": [0.0, 90.0, 0.0]}, "test")
CONFIG = Ros1KinectConfig(calibration_file="unused", transfer_centre_m=[0.5, 0.0, 0.0])


class Camera:
    """The ROS side: publishes raw ROS 1 bytes on the keys the tracker reads."""

    def __init__(self, node) -> None:
        t = CONFIG.topics
        self.tf = node.session.declare_publisher(topic_key(t.tf, TFMessage.TYPE))
        self.image = node.session.declare_publisher(topic_key(t.depth_image, Image.TYPE))
        self.info = node.session.declare_publisher(topic_key(t.camera_info, CameraInfo.TYPE))

    def skeleton(self, body_camera: np.ndarray, user: int, stamp_ns: int) -> None:
        for data in wire(body_camera, user, stamp_ns):
            self.tf.put(data)

    def depth(self, stamp_ns: int, mm: int = 1500) -> None:
        header = Header(stamp=Time.from_ns(stamp_ns), frame_id="camera_depth_optical_frame")
        k = (100.0, 0.0, 3.5, 0.0, 100.0, 2.5, 0.0, 0.0, 1.0)
        self.info.put(CameraInfo(header, 6, 8, "plumb_bob", (0.0,) * 5, k).to_bytes())
        self.image.put(Image(header, 6, 8, "16UC1", 0, 16, np.full(48, mm, "<u2").tobytes()).to_bytes())


def body_at(torso_base_xy: tuple[float, float]) -> np.ndarray:
    """15 joints (camera frame) of a body whose torso is at `torso_base_xy` in base, 0.1 m up."""
    x, y = torso_base_xy
    torso_camera = np.array([0.9, y, x - 0.2])  # base (0.2 + z, y, 1 - x)
    return torso_camera + (np.arange(15) - 2)[:, None] * np.array([0.04, 0.0, 0.0])  # joint 2: the torso


@pytest.fixture
def rig(make_node):
    tracker = make_node("tracker")
    config = config_from_dict({"sensor": "ros1", "ros1": {"calibration_file": "unused"}})
    feeder = _Feeder(TrackerPipeline(config, ArmGeometry()))
    inputs = Ros1KinectInputs(CONFIG, POSE, tracker)
    watcher = make_node("watcher")
    skeletons = watcher.subscribe(T.SKELETON, queue_size=1000)
    camera = Camera(make_node("camera"))
    time.sleep(0.3)  # let the subscriptions reach the router
    yield inputs, feeder, camera, skeletons
    inputs.close()


def feed_until(inputs, feeder, predicate, timeout_s: float = 5.0) -> bool:
    return wait_until(lambda: inputs.feed(feeder, time.monotonic()) and predicate(), timeout_s)


def test_the_receivers_skeleton_reaches_the_pipeline_in_base(rig):
    inputs, feeder, camera, skeletons = rig
    camera.skeleton(body_at((1.6, 1.0)), user=4, stamp_ns=10**9)  # a bystander, 1.4 m from the centre
    camera.skeleton(body_at((1.0, -0.2)), user=7, stamp_ns=10**9)  # the receiver, 0.54 m away
    # The two may come in different ticks (the bystander first, then the receiver, 0.9 m nearer
    # the table than it, takes over): the receiver is user 7 once both are in.
    assert feed_until(inputs, feeder, lambda: inputs.assembler.frames == 2), inputs.stats()
    assert inputs.chooser.receiver == 7
    # Whether or not the bystander was fed first, nothing of it is left in the pipeline's
    # torso (a median over recent frames): the switch made the pipeline forget it.
    state = feeder.pipe.human_state(time.monotonic())
    assert state.tracked
    np.testing.assert_allclose(state.torso_m, [1.0, -0.2, 0.1], atol=1e-9)
    assert wait_until(lambda: skeletons.latest() is not None and skeletons.latest().msg.user_id == 7, 2.0)
    msg = skeletons.latest().msg
    assert msg.tracked and msg.user_id == 7 and [j.name for j in msg.joints] == list(SKELETON_JOINTS)
    np.testing.assert_allclose(msg.joints[2].position_m, [1.0, -0.2, 0.1], atol=1e-9)
    assert inputs.stats()["frames"] == 2 and inputs.stats()["skeletons"] in (1, 2)


def test_malformed_payloads_are_counted_and_dropped_and_the_source_goes_on(rig):
    inputs, feeder, camera, _ = rig
    for junk in (b"", b"\xff" * 3, b"\xff\xff\xff\x7f" + bytes(20), bytes(range(256))):
        camera.tf.put(junk)
        camera.image.put(junk)
        camera.info.put(junk)
    assert feed_until(inputs, feeder, lambda: inputs.tf.rejected == 4 and inputs.image.rejected == 4
                      and inputs.info.rejected == 4), inputs.stats()
    camera.skeleton(body_at((1.0, 0.0)), user=1, stamp_ns=10**9)
    camera.depth(10**9)
    assert feed_until(inputs, feeder, lambda: feeder.human and inputs.depth_frames == 1), inputs.stats()


def test_the_loss_of_the_skeleton_is_reported_and_a_late_depth_image_dropped(rig):
    inputs, feeder, camera, skeletons = rig
    camera.skeleton(body_at((1.0, 0.0)), user=1, stamp_ns=10**9)
    camera.depth(2 * 10**9)
    assert feed_until(inputs, feeder, lambda: feeder.human and inputs.depth_frames == 1), inputs.stats()
    camera.depth(10**9)  # older than the one already used
    assert feed_until(inputs, feeder, lambda: inputs.depth_out_of_order == 1), inputs.stats()
    assert inputs.depth_frames == 1
    # openni_tracker stops sending: after the tracker's skeleton time-out the human is not tracked,
    # and not-tracked skeletons go out for the recorder.
    timeout_s = feeder.pipe.config.skeleton_timeout_s
    lost_from = time.monotonic()
    assert feed_until(inputs, feeder, lambda: not feeder.pipe.human_state(time.monotonic()).tracked,
                      timeout_s + 2.0)
    assert time.monotonic() - lost_from >= timeout_s - 0.05
    assert "stale" in feeder.pipe.human_state(time.monotonic()).status
    assert wait_until(lambda: any(not rx.msg.tracked for rx in skeletons.drain()), 2.0)


def test_a_switch_of_receiver_leaves_nothing_of_the_previous_person_in_the_pipeline(rig):
    inputs, feeder, camera, _ = rig
    camera.skeleton(body_at((1.6, 1.0)), user=4, stamp_ns=10**9)  # only the bystander so far
    assert feed_until(inputs, feeder, lambda: inputs.chooser.receiver == 4), inputs.stats()
    np.testing.assert_allclose(feeder.pipe.human_state(time.monotonic()).torso_m, [1.6, 1.0, 0.1], atol=1e-9)
    camera.skeleton(body_at((1.0, -0.2)), user=7, stamp_ns=2 * 10**9)  # the receiver walks in
    assert feed_until(inputs, feeder, lambda: inputs.chooser.receiver == 7), inputs.stats()
    np.testing.assert_allclose(feeder.pipe.human_state(time.monotonic()).torso_m, [1.0, -0.2, 0.1], atol=1e-9)
    assert inputs.chooser.switches == 2
