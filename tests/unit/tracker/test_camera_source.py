"""`CameraInputs` on a real loopback bus with the real pose model: a camera that stops
delivering makes the receiver lost (the human state says not tracked, never a stale hand), and
frames out of order are dropped."""

from __future__ import annotations

import time

import numpy as np
import pytest

pytest.importorskip("mediapipe", reason="the camera extra is not installed (docs/camera.md#install)")
pytest.importorskip("skimage", reason="the camera extra (scikit-image's photos) is not installed")

from bus_schema import topics as T  # noqa: E402
from handover_model.robot_geometry import ArmGeometry  # noqa: E402
from services.runtime.testing import wait_until  # noqa: E402
from services.tracker.camera import photos  # noqa: E402
from services.tracker.camera.capture import Frame, Intrinsics  # noqa: E402
from services.tracker.camera.config import CameraConfig  # noqa: E402
from services.tracker.camera.pose2d import PoseEstimator  # noqa: E402
from services.tracker.camera.source import CameraInputs  # noqa: E402
from services.tracker.camera.worker import Rig  # noqa: E402
from services.tracker.config import TrackerConfig  # noqa: E402
from services.tracker.core import TrackerPipeline  # noqa: E402
from services.tracker.node import _Feeder  # noqa: E402
from services.tracker.ros1.calibration import parse_calibration  # noqa: E402

POSE = parse_calibration({"position_m": list(photos.SAMPLE_CAMERA_POSITION_M), "rpy_deg": [0, 0, 0]}, "test")


class LiveCamera:
    """A live camera that delivers `frames` (rgb, stamp) and then nothing (unplugged)."""

    live = True

    def __init__(self, frames: list[tuple[np.ndarray, float]]) -> None:
        self.frames, self.read_failures = list(frames), 0

    def read(self):
        if not self.frames:
            self.read_failures += 1
            time.sleep(0.01)
            return None
        rgb, stamp = self.frames.pop(0)
        time.sleep(0.05)  # slower than the 50 Hz rate: no frame is skipped for the rate
        return Frame(0, rgb, stamp, photos.flat_depth({"right": 1.5}))

    def close(self) -> None:
        pass


def inputs_for(frames, make_node):
    config = CameraConfig(input="0", calibration_file="x", object_position_m=[0.72, -0.55, -0.17],
                          stall_s=0.5, rate_hz=50.0, **photos.SAMPLE_INTRINSICS_PX)
    k = photos.SAMPLE_INTRINSICS_PX
    rig = Rig(config, LiveCamera(frames), None, Intrinsics(k["fx_px"], k["fy_px"], k["cx_px"], k["cy_px"]), POSE,
              PoseEstimator(max_people=1))
    pipe = TrackerPipeline(TrackerConfig(lag_correction=False, proximity_filter=False), ArmGeometry())
    node = make_node("tracker")
    return CameraInputs(rig, node, node.publisher(T.OBJECT)), _Feeder(pipe)


def test_a_camera_that_stops_delivering_makes_the_receiver_lost(make_node):
    man, _ = photos.compose([("cameraman", "right")])
    inputs, feeder = inputs_for([(man, 0.1 * i) for i in range(1, 6)], make_node)
    try:
        def fed_and_tracked() -> bool:
            inputs.feed(feeder, time.monotonic())
            return feeder.pipe.human_state(time.monotonic()).tracked
        assert wait_until(fed_and_tracked, 20.0)
        hand = feeder.pipe.human_state(time.monotonic()).hand_m.copy()
        assert np.all(np.isfinite(hand))

        def lost() -> bool:
            inputs.feed(feeder, time.monotonic())
            return not feeder.pipe.human_state(time.monotonic()).tracked
        started = time.monotonic()
        assert wait_until(lost, 5.0)
        assert time.monotonic() - started < 2.0  # stall_s 0.5 plus the frames still queued
        state = feeder.pipe.human_state(time.monotonic())
        assert state.status == "no person tracked"
    finally:
        inputs.close()


def test_frames_out_of_order_are_dropped_and_counted(make_node):
    man, _ = photos.compose([("cameraman", "right")])
    inputs, feeder = inputs_for([(man, 1.0), (man, 0.5), (man, 1.0), (man, 2.0)], make_node)
    try:
        assert wait_until(lambda: inputs.worker.stats.frames + inputs.worker.stats.out_of_order == 4, 20.0)
        assert inputs.worker.stats.out_of_order == 2
        assert inputs.worker.stats.frames == 2
    finally:
        inputs.close()
