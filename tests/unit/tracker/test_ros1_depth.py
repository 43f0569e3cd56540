"""The depth camera's Image + CameraInfo → `perception/depth` fields: encodings, byte orders, row
padding, refusals; and the fake OpenNI's messages give back the simulated Kinect's frame."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema import topics as T
from services.bridge.baxter.messages import Header
from services.tracker.pointcloud import depth_frame_from_message
from services.tracker.ros1.calibration import CameraPose, parse_calibration
from services.tracker.ros1.depth import DepthConversionError, depth_fields
from services.tracker.ros1.messages import CameraInfo, Image

POSE = parse_calibration({"position_m": [0.1, 0.0, 0.95], "rpy_deg": [0.0, 44.0, -21.0]}, "test")
K = (5.0, 0.0, 1.5, 0.0, 6.0, 0.5, 0.0, 0.0, 1.0)
MM = np.array([[500, 1000, 0, 4500], [65535, 1, 2, 3]], dtype=np.uint16)  # 4 x 2 pixels


def info(width: int = 4, height: int = 2) -> CameraInfo:
    return CameraInfo(Header(frame_id="camera_depth_optical_frame"), height, width, "plumb_bob", (0.0,) * 5, K)


def image(data: bytes, encoding: str = "16UC1", big: bool = False, step: int = 8) -> Image:
    return Image(Header(frame_id="camera_depth_optical_frame"), 2, 4, encoding, int(big), step, data)


def roundtrip(msg):
    return type(msg).from_bytes(msg.to_bytes())


def test_16uc1_in_either_byte_order_and_with_padded_rows():
    little = depth_fields(roundtrip(image(MM.astype("<u2").tobytes())), roundtrip(info()), POSE)
    big = depth_fields(roundtrip(image(MM.astype(">u2").tobytes(), big=True)), info(), POSE)
    padded_rows = np.zeros((2, 12), np.uint8)  # 8 bytes of pixels + 4 of padding per row
    padded_rows[:, :8] = np.frombuffer(MM.astype("<u2").tobytes(), np.uint8).reshape(2, 8)
    padded = depth_fields(image(padded_rows.tobytes(), step=12), info(), POSE)
    for fields in (little, big, padded):
        assert np.array_equal(np.frombuffer(fields["depth_mm"], "<u2").reshape(2, 4), MM)
    assert (little["fx"], little["fy"], little["cx"], little["cy"]) == (5.0, 6.0, 1.5, 0.5)
    assert little["camera_position_m"] == (0.1, 0.0, 0.95)
    assert np.allclose(little["camera_orientation_xyzw"], POSE.optical_orientation_xyzw())


def test_32fc1_metres_become_millimetres_and_nan_no_reading():
    metres = np.array([[0.5, 1.0, np.nan, 4.5], [70.0, -1.0, 0.0015, np.inf]], dtype="<f4")
    fields = depth_fields(image(metres.tobytes(), "32FC1", step=16), info(), POSE)
    assert np.frombuffer(fields["depth_mm"], "<u2").tolist() == [500, 1000, 0, 4500, 65535, 0, 2, 0]


@pytest.mark.parametrize(("msg", "camera", "expected"), [
    (image(MM.tobytes(), "rgb8"), info(), "encoding 'rgb8'"),
    (image(MM.tobytes()[:-2]), info(), "do not match"),
    (image(MM.tobytes(), step=6), info(), "do not match"),
    (image(MM.tobytes()), info(8, 2), "camera_info is for 8x2"),
    (image(MM.tobytes()), CameraInfo(height=2, width=4), "no positive focal lengths"),
    (Image(height=2000, width=2, encoding="16UC1", step=4, data=bytes(8000)), info(2, 2000), "too large"),
])
def test_images_that_cannot_be_depth_frames_are_refused_in_one_line(msg, camera, expected):
    with pytest.raises(DepthConversionError, match=expected) as err:
        depth_fields(msg, camera, POSE)
    assert "\n" not in str(err.value)


def test_the_fake_openni_messages_give_back_the_simulated_kinects_frame():
    from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
    from robot_sim.kinect.sim import KinectSim
    from services.bridge.baxter.fake_openni import depth_messages

    sim = KinectSim(5)
    frame = sim.step(0.0, np.array(RIGHT_ARM_HOME_RAD))
    image_msg, info_msg = depth_messages(frame.depth_fields, "camera_depth_optical_frame", 1)
    pose = CameraPose.from_optical(sim.camera.position_m, sim.camera.rotation)
    fields = depth_fields(roundtrip(image_msg), roundtrip(info_msg), pose)
    sim_fields = frame.depth_fields
    assert fields["depth_mm"] == sim_fields["depth_mm"]
    for key in ("width", "height", "fx", "fy", "cx", "cy"):
        assert fields[key] == sim_fields[key]
    np.testing.assert_allclose(fields["camera_position_m"], sim_fields["camera_position_m"], atol=1e-12)
    np.testing.assert_allclose(fields["camera_orientation_xyzw"], sim_fields["camera_orientation_xyzw"], atol=1e-12)
    # The tracker's point cloud of the converted frame is the simulated one's.
    ours = depth_frame_from_message(T.DEPTH.type(seq=0, stamp_ns=0, source="t", **fields), 0.0)
    theirs = depth_frame_from_message(T.DEPTH.type(seq=0, stamp_ns=0, source="t", **sim_fields), 0.0)
    np.testing.assert_allclose(ours.camera_rotation, theirs.camera_rotation, atol=1e-9)
    np.testing.assert_allclose(ours.camera_rotation, sim.camera.rotation, atol=1e-9)
    assert np.array_equal(np.isnan(ours.depth_m), np.isnan(theirs.depth_m))
