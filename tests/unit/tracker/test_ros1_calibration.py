"""The ROS 1 camera's calibration: a known pose maps known points to known base-frame points,
the file's errors are one line each, the fake's file is the simulated camera's real pose, and
the point-pair solver recovers a pose."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from services.tracker.errors import CalibrationError
from services.tracker.ros1.calibration import (
    OPTICAL_IN_CAMERA,
    CameraPose,
    calibration_text,
    load_calibration,
    parse_calibration,
    solve_camera_pose,
)

REPO = Path(__file__).resolve().parents[3]


def test_a_known_pose_maps_known_points_into_base():
    # Camera 1 m up, 0.2 m forward, pitched 90 degrees down: its x (forward) is base -z, its
    # y (left) base y, its z (up) base x.
    pose = parse_calibration({"position_m": [0.2, 0.0, 1.0], "rpy_deg": [0.0, 90.0, 0.0]}, "test")
    points = pose.to_base(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.5, 0.0], [2.0, 0.0, 0.3]]))
    np.testing.assert_allclose(points, [[0.2, 0.0, 1.0], [0.2, 0.0, 0.0], [0.2, 0.5, 0.0], [0.5, 0.0, -1.0]],
                               atol=1e-12)
    np.testing.assert_allclose(pose.from_base(points[3]), [2.0, 0.0, 0.3], atol=1e-12)


def test_a_yawed_camera_and_the_quaternion_form_agree():
    # Yaw 90 degrees: the camera looks along base +y; a point 2 m ahead, 0.5 m to its left.
    rpy = parse_calibration({"position_m": [1.0, 2.0, 0.5], "rpy_deg": [0.0, 0.0, 90.0]}, "rpy")
    s = float(np.sqrt(0.5))
    quat = parse_calibration({"position_m": [1.0, 2.0, 0.5], "orientation_xyzw": [0.0, 0.0, s, s]}, "quat")
    np.testing.assert_allclose(rpy.to_base([2.0, 0.5, 0.0]), [0.5, 4.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(quat.to_base([2.0, 0.5, 0.0]), [0.5, 4.0, 0.5], atol=1e-12)


def test_the_optical_frame_looks_along_the_camera_x_with_image_x_to_the_right():
    pose = CameraPose(np.zeros(3), np.eye(3))
    # Optical z (depth) is the camera's x, optical x (image right) its -y, optical y (down) its -z.
    np.testing.assert_allclose(OPTICAL_IN_CAMERA @ [0, 0, 1], [1, 0, 0])
    np.testing.assert_allclose(OPTICAL_IN_CAMERA @ [1, 0, 0], [0, -1, 0])
    np.testing.assert_allclose(OPTICAL_IN_CAMERA @ [0, 1, 0], [0, 0, -1])
    x, y, z, w = pose.optical_orientation_xyzw()
    np.testing.assert_allclose(Rotation.from_quat([x, y, z, w]).as_matrix(), OPTICAL_IN_CAMERA, atol=1e-12)
    assert w >= 0


def test_the_fake_profiles_calibration_is_the_simulated_cameras_real_pose():
    from robot_sim.kinect.camera import KinectCamera

    camera = KinectCamera()
    real = CameraPose.from_optical(camera.position_m, camera.rotation)
    assert not np.allclose(real.rotation, np.eye(3), atol=0.1)  # the calibration is exercised
    shipped = load_calibration(REPO / "deploy" / "kinect_calibration_fake.toml", "openni_depth_frame")
    np.testing.assert_allclose(shipped.position_m, real.position_m, atol=1e-4)
    # A point at the receiver's distance lands within 0.1 mm of where the camera sees it.
    ahead = np.array([[1.5, 0.2, -0.3], [0.8, -0.4, 0.1]])
    np.testing.assert_allclose(shipped.to_base(ahead), real.to_base(ahead), atol=1e-4)
    np.testing.assert_allclose(real.optical_rotation, camera.rotation, atol=1e-12)


@pytest.mark.parametrize(("text", "expected"), [
    ("position_m = [0, 0, 1]\nrpy_deg = [0, 0, 0]\nyaw = 3\n", "yaw"),
    ("position_m = [0, 0]\nrpy_deg = [0, 0, 0]\n", "position_m"),
    ("position_m = [0, 0, 1]\n", "exactly one of orientation_xyzw and rpy_deg"),
    ("position_m = [0, 0, 1]\nrpy_deg = [0, 0, 0]\norientation_xyzw = [0, 0, 0, 1]\n", "exactly one"),
    ("position_m = [0, 0, 1]\norientation_xyzw = [0, 0, 0, 2]\n", "not a unit quaternion"),
    ("position_m = [100, 0, 950]\nrpy_deg = [0, 0, 0]\n", "metres, not mm"),
    ("position_m = [0, 0, 1]\nrpy_deg = [0, 0, nan]\n", "rpy_deg"),
    ("position_m = [0, 0, 1]\nrpy_deg = [0, 0, 0]\nframe = \"camera_link\"\n", "camera_link"),
    ("position_m = [0, 0, 1\n", "not valid TOML"),
])
def test_an_invalid_calibration_file_is_one_line_naming_the_problem(tmp_path, text, expected):
    path = tmp_path / "cal.toml"
    path.write_text(text)
    with pytest.raises(CalibrationError) as err:
        load_calibration(path, "openni_depth_frame")
    message = str(err.value)
    assert expected in message and str(path) in message and "\n" not in message
    assert err.value.bad_input  # exit 2: a usage error


def test_a_missing_calibration_file_says_where_to_measure_it(tmp_path):
    with pytest.raises(CalibrationError, match=r"does not exist .*docs/kinect_ros1.md#calibration"):
        load_calibration(tmp_path / "nowhere.toml")


def test_the_solver_recovers_a_pose_from_noisy_point_pairs():
    rng = np.random.default_rng(3)
    true = CameraPose(np.array([0.1, -0.05, 0.95]), Rotation.from_euler("xyz", [2.0, 40.0, -20.0],
                                                                         degrees=True).as_matrix())
    camera_points = rng.uniform([0.8, -0.6, -0.8], [2.0, 0.6, 0.2], size=(8, 3))
    base_points = true.to_base(camera_points) + rng.normal(0.0, 0.002, size=(8, 3))  # 2 mm noise
    pose, residuals = solve_camera_pose(camera_points, base_points)
    assert np.linalg.norm(pose.position_m - true.position_m) < 0.01
    angle = Rotation.from_matrix(pose.rotation.T @ true.rotation).magnitude()
    assert np.degrees(angle) < 0.5
    assert residuals.shape == (8,) and residuals.max() < 0.01
    # The written file reads back as the same pose.
    again = parse_calibration(tomllib.loads(calibration_text(pose, "openni_depth_frame", "test")), "text")
    np.testing.assert_allclose(again.to_base(camera_points), pose.to_base(camera_points), atol=1e-4)


def test_the_solver_refuses_too_few_or_collinear_points():
    with pytest.raises(CalibrationError, match="at least 4"):
        solve_camera_pose(np.zeros((3, 3)), np.zeros((3, 3)))
    line = np.outer(np.linspace(0, 1, 5), [1.0, 0.0, 0.0])
    with pytest.raises(CalibrationError, match="line"):
        solve_camera_pose(line, line)


def test_the_tracker_refuses_to_start_without_its_calibration_file(tmp_path):
    profile = tmp_path / "p.toml"
    profile.write_text('[bus]\nendpoint = "tcp/127.0.0.1:1"\n[services.tracker]\nmodule = "services.tracker"\n'
                       '[services.tracker.config]\nsensor = "ros1"\n[services.tracker.config.ros1]\n'
                       'calibration_file = "kinect.toml"\n')
    run = subprocess.run([sys.executable, "-m", "services.tracker", "--profile", str(profile)],
                         capture_output=True, text=True, timeout=60)
    lines = [line for line in (run.stdout + run.stderr).splitlines() if line.strip()]
    assert run.returncode == 2, lines
    assert lines[-1] == (f"tracker: error: calibration file {tmp_path / 'kinect.toml'} does not exist (measure the "
                         "camera's pose in base: docs/kinect_ros1.md#calibration)")
    profile.write_text(profile.read_text().replace('calibration_file = "kinect.toml"\n', ""))
    run = subprocess.run([sys.executable, "-m", "services.tracker", "--profile", str(profile)],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "needs ros1.calibration_file" in run.stdout + run.stderr


def test_calibrate_kinect_writes_a_file_the_tracker_loads(tmp_path):
    true = CameraPose(np.array([0.12, -0.03, 0.9]), Rotation.from_euler("xyz", [0, 35, -15], degrees=True).as_matrix())
    camera_points = np.array([[1.0, 0.3, -0.2], [1.4, -0.3, -0.5], [0.9, -0.1, 0.1], [1.8, 0.4, -0.6],
                              [1.2, 0.0, -0.3]])
    rows = np.hstack([camera_points, true.to_base(camera_points)])
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("camera_x,camera_y,camera_z,base_x,base_y,base_z\n"
                     + "".join(",".join(f"{v:.6f}" for v in row) + "\n" for row in rows))
    out = tmp_path / "kinect.toml"
    command = [sys.executable, "-m", "services.tracker", "calibrate-kinect", str(pairs), "-o", str(out)]
    run = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "rms 0.0 mm" in run.stdout
    pose = load_calibration(out, "openni_depth_frame")
    np.testing.assert_allclose(pose.to_base(camera_points), rows[:, 3:], atol=2e-4)
    again = subprocess.run(command, capture_output=True, text=True, timeout=60)  # no silent overwrite
    assert again.returncode == 2 and "exists: pass --force" in again.stdout + again.stderr
