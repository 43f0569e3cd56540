"""2-D landmarks + depth → joints in base; the receiver rule; the frame sources' errors."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from services.tracker.camera.capture import DepthFolder, Frame, FrameOrder, Intrinsics, OpenCvFrames, SourceEnded
from services.tracker.camera.config import CameraConfig
from services.tracker.camera.lift import lift_person
from services.tracker.camera.people import ReceiverRule
from services.tracker.camera.pose2d import LM, Person2D
from services.tracker.errors import CameraError
from services.tracker.ros1.calibration import CameraPose

K = Intrinsics(500.0, 500.0, 320.0, 240.0)
LEVEL = CameraPose(np.array([0.0, 0.0, 0.5]), np.eye(3))  # camera frame = base axes, 0.5 m up


def person(points: dict[str, tuple[float, float]], visibility: float = 0.9) -> Person2D:
    xy = np.full((33, 2), 320.0)
    for name, p in points.items():
        xy[LM[name]] = p
    return Person2D(xy, np.full(33, visibility))


STANDING = {"nose": (320, 100), "left_ear": (340, 95), "right_ear": (300, 95), "right_shoulder": (230, 160),
            "left_shoulder": (410, 160), "right_elbow": (220, 260), "left_elbow": (420, 260),
            "right_wrist": (200, 330), "right_index": (200, 340), "right_pinky": (200, 335),
            "left_wrist": (440, 330), "left_index": (440, 340), "left_pinky": (440, 335),
            "left_hip": (380, 360), "right_hip": (260, 360)}


def test_a_joint_goes_to_base_through_depth_intrinsics_and_calibration():
    depth = np.full((480, 640), 2000, np.uint16)
    p3 = lift_person(person(STANDING), K, LEVEL, depth, 0.5, 0.36)
    assert p3 is not None
    # right shoulder: 90 px left of the centre, 80 px above, 2 m away → x 2, y +0.36, z 0.5 + 0.32
    np.testing.assert_allclose(p3.joints_m["right_shoulder"], [2.0, 0.36, 0.82], atol=1e-9)
    np.testing.assert_allclose(p3.joints_m["neck"], [2.0, 0.0, 0.82], atol=1e-9)
    np.testing.assert_allclose(p3.joints_m["torso"], [2.0, 0.0, 0.5 + (240 - 260) / 500 * 2.0], atol=1e-9)
    assert set(p3.joints_m) >= {"head", "right_hand", "left_hand", "left_hip"}


def test_a_hole_in_the_depth_takes_the_shoulders_depth_and_hidden_joints_are_left_out():
    depth = np.full((480, 640), 1500, np.uint16)
    depth[320:350, 190:210] = 0  # no reading at the right hand
    p = person(STANDING)
    p.visibility[LM["left_knee"]] = 0.2
    p3 = lift_person(p, K, LEVEL, depth, 0.5, 0.36)
    assert p3 is not None
    assert p3.joints_m["right_hand"][0] == pytest.approx(1.5)
    assert "left_knee" not in p3.joints_m


def test_without_depth_the_distance_comes_from_the_shoulder_width():
    p3 = lift_person(person(STANDING), K, LEVEL, None, 0.5, 0.36)  # 180 px apart: 500 * 0.36 / 180 = 1 m
    assert p3 is not None
    assert p3.joints_m["right_shoulder"][0] == pytest.approx(1.0)
    assert p3.joints_m["left_shoulder"][1] - p3.joints_m["right_shoulder"][1] == pytest.approx(-0.36)


def test_no_distance_no_person():
    assert lift_person(person(STANDING), K, LEVEL, np.zeros((480, 640), np.uint16), 0.5, 0.36) is None


def test_the_receiver_is_the_person_nearest_the_transfer_centre_and_stays():
    rule = ReceiverRule([1.0, 0.0, 0.0], max_distance_m=1.5, margin_m=0.3)
    near, far = np.array([1.2, 0.1, 0.2]), np.array([1.0, 1.0, 0.2])
    assert rule.choose([far, near]) == 1
    assert rule.choose([near + 0.05, far - [0.0, 0.7, 0.0]]) == 0  # the other is nearer by < margin: keep
    assert rule.choose([near, np.array([1.0, 0.0, 0.2])]) == 0  # nearer by 0.22 < 0.3: keep
    assert rule.choose([np.array([1.9, 0.8, 0.2]), np.array([0.6, -0.5, 0.2])]) == 1  # receiver gone
    assert rule.choose([np.array([3.0, 0.0, 0.2])]) is None  # outside the transfer region
    assert rule.switches == 2


def test_frames_out_of_order_are_dropped():
    order = FrameOrder()
    rgb = np.zeros((2, 2, 3), np.uint8)
    kept = [order.keep(Frame(i, rgb, t)) for i, t in enumerate([0.0, 0.1, 0.05, 0.1, 0.2])]
    assert kept == [True, True, False, False, True]
    assert order.dropped == 2


def test_an_image_folder_is_read_in_order_then_ends(tmp_path):
    for i in (2, 0, 1):
        cv2.imwrite(str(tmp_path / f"{i:04d}.png"), np.full((4, 6, 3), i * 50, np.uint8))
    frames = OpenCvFrames(str(tmp_path), 10.0, loop=False)
    got = [frames.read() for _ in range(3)]
    assert [int(f.rgb[0, 0, 0]) for f in got] == [0, 50, 100]
    assert [f.stamp_s for f in got] == pytest.approx([0.0, 0.1, 0.2])
    with pytest.raises(SourceEnded):
        frames.read()


@pytest.mark.parametrize("spec,match", [("/nonexistent/video.avi", "neither a device"),
                                        ("EMPTY", "holds no image"), ("BAD", "cannot be opened")])
def test_no_camera_gives_one_clear_line(tmp_path, spec, match):
    if spec == "EMPTY":
        spec = str(tmp_path)
    elif spec == "BAD":
        (tmp_path / "x.avi").write_bytes(b"not a video")
        spec = str(tmp_path / "x.avi")
    with pytest.raises(CameraError, match=match):
        OpenCvFrames(spec, 10.0, loop=False)


def test_a_depth_image_of_the_wrong_kind_is_refused(tmp_path):
    cv2.imwrite(str(tmp_path / "0000.png"), np.zeros((4, 6, 3), np.uint8))
    with pytest.raises(CameraError, match="16-bit"):
        DepthFolder(tmp_path).get(0, (4, 6))
    cv2.imwrite(str(tmp_path / "0000.png"), np.zeros((4, 6), np.uint16))
    with pytest.raises(CameraError, match="aligned"):
        DepthFolder(tmp_path).get(0, (8, 6))


def test_an_incomplete_camera_set_up_says_what_is_missing():
    problems = CameraConfig(input="x.avi").problems()
    assert any("calibration_file" in p for p in problems)
    assert any("fx_px" in p for p in problems)
    assert any("object_position_m" in p for p in problems)
    ok = CameraConfig(input="x.avi", calibration_file="c.toml", fx_px=1, fy_px=1, cx_px=1, cy_px=1,
                      object_position_m=[0.7, -0.5, -0.2])
    assert ok.problems() == []


def test_the_tracker_cli_refuses_an_incomplete_camera_set_up_in_one_line(tmp_path, capsys):
    from services.tracker.cli import main

    assert main(["--sensor", "camera"]) == 2
    assert "camera.calibration_file is required" in capsys.readouterr().err
    profile = tmp_path / "p.toml"
    text = (Path(__file__).resolve().parents[3] / "deploy" / "camera.toml").read_text()
    profile.write_text(text.replace('"camera_sample/calibration.toml"', '"missing.toml"'))
    assert main(["--profile", str(profile)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "calibration file" in err[0] and "does not exist" in err[0]
