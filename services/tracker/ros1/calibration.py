"""The depth camera's pose in the robot's `base` frame: the calibration of the ROS 1 Kinect path.

Frames (all right-handed, metres):

- `base`: Baxter's base frame (x forward, y left, z up).
- camera frame: ``openni_depth_frame`` (openni_tracker's ``camera_frame_id``; with
  openni_launch the same as ``camera_depth_frame``): x forward along the optical axis, y left,
  z up. The skeleton's `/tf` positions are in it. The calibration is this frame's pose in `base`.
- optical frame: ``camera_depth_optical_frame``: z forward, x right, y down, same origin
  (openni_launch's static transform). The depth image is in it.

The calibration file (TOML, named by ``[services.tracker.config.ros1] calibration_file``,
relative to the profile's folder)::

    frame = "openni_depth_frame"          # optional: must equal the skeleton's frame
    position_m = [0.10, 0.00, 0.95]       # the camera frame's origin in base, m
    rpy_deg = [0.0, 33.2, -24.1]          # roll, pitch, yaw about base's fixed x, y, z, degrees
    # or orientation_xyzw = [x, y, z, w]  # a unit quaternion (exactly one of the two)

`solve_camera_pose` computes it from points measured in both frames (docs/kinect_ros1.md).
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import msgspec
import numpy as np
from msgspec import Meta
from scipy.spatial.transform import Rotation

from services.tracker.errors import CalibrationError

#: Rotation (3, 3) from the optical frame (z forward, x right, y down) to the camera frame
#: (x forward, y left, z up): its columns are the optical axes in the camera frame.
OPTICAL_IN_CAMERA = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])

Finite = Annotated[float, Meta(ge=-1e6, le=1e6)]


@dataclass(frozen=True)
class CameraPose:
    """The camera frame's pose in `base`.

    Attributes:
        position_m: (3,) the camera frame's origin in `base`, m.
        rotation: (3, 3) rotation from the camera frame to `base` (p_base = R p_cam + t).
    """

    position_m: np.ndarray
    rotation: np.ndarray

    def to_base(self, points_camera_m: np.ndarray) -> np.ndarray:
        """Camera-frame points (..., 3), m, in `base`, m."""
        return np.asarray(points_camera_m, float) @ self.rotation.T + self.position_m

    def from_base(self, points_base_m: np.ndarray) -> np.ndarray:
        """`base` points (..., 3), m, in the camera frame, m."""
        return (np.asarray(points_base_m, float) - self.position_m) @ self.rotation

    @property
    def optical_rotation(self) -> np.ndarray:
        """(3, 3) rotation from the optical frame to `base`."""
        return self.rotation @ OPTICAL_IN_CAMERA

    def optical_orientation_xyzw(self) -> tuple[float, float, float, float]:
        """The optical frame's orientation in `base`, unit quaternion (x, y, z, w), w >= 0
        (as `bus_schema.messages.DepthImage.camera_orientation_xyzw`)."""
        q = Rotation.from_matrix(self.optical_rotation).as_quat()
        if q[3] < 0:
            q = -q
        x, y, z, w = (float(v) for v in q)
        return x, y, z, w

    @classmethod
    def from_optical(cls, position_m: np.ndarray, optical_rotation: np.ndarray) -> CameraPose:
        """The pose of a camera whose optical frame is at `position_m` with rotation
        `optical_rotation` (optical → `base`), as `robot_sim.kinect.camera.KinectCamera` gives it."""
        return cls(np.asarray(position_m, float).copy(), np.asarray(optical_rotation, float) @ OPTICAL_IN_CAMERA.T)

    def rpy_deg(self) -> tuple[float, float, float]:
        """Roll, pitch, yaw about `base`'s fixed x, y, z (as tf_echo prints), degrees."""
        r, p, y = Rotation.from_matrix(self.rotation).as_euler("xyz", degrees=True)
        return float(r), float(p), float(y)


class _CalibrationFile(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    position_m: Annotated[list[Finite], Meta(min_length=3, max_length=3)]
    orientation_xyzw: Annotated[list[Finite], Meta(min_length=4, max_length=4)] | None = None
    rpy_deg: Annotated[list[Finite], Meta(min_length=3, max_length=3)] | None = None
    frame: str | None = None
    measured: str = ""  # free text: when, by whom, how (kept in the file for the record)


#: The camera's distance from the base origin beyond which a calibration is a typo, m.
MAX_CAMERA_DISTANCE_M = 10.0


def parse_calibration(table: dict, where: str, frame: str | None = None) -> CameraPose:
    """The pose in a calibration table (see the module docstring).

    Args:
        where: names the source in errors (the file).
        frame: the camera frame the skeleton comes in; a table that names another is refused.

    Raises:
        CalibrationError: one line naming `where` and the bad key.
    """
    try:
        cal = msgspec.convert(table, _CalibrationFile)
    except msgspec.ValidationError as exc:
        raise CalibrationError(f"calibration {where} is invalid: {exc}") from None
    if frame is not None and cal.frame is not None and cal.frame != frame:
        raise CalibrationError(f"calibration {where} is the pose of frame {cal.frame!r}, but the skeleton "
                               f"comes in {frame!r} ([services.tracker.config.ros1] skeleton_frame_id)")
    position = np.array(cal.position_m, float)
    if np.linalg.norm(position) > MAX_CAMERA_DISTANCE_M:
        raise CalibrationError(f"calibration {where}: position_m {cal.position_m} is more than "
                               f"{MAX_CAMERA_DISTANCE_M:g} m from the base origin (metres, not mm?)")
    if (cal.orientation_xyzw is None) == (cal.rpy_deg is None):
        raise CalibrationError(f"calibration {where} needs exactly one of orientation_xyzw and rpy_deg")
    if cal.orientation_xyzw is not None:
        q = np.array(cal.orientation_xyzw, float)
        if abs(np.linalg.norm(q) - 1.0) > 0.01:
            raise CalibrationError(f"calibration {where}: orientation_xyzw {cal.orientation_xyzw} is not a unit "
                                   f"quaternion (norm {np.linalg.norm(q):.4f}; order x, y, z, w)")
        rotation = Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()
    else:
        rotation = Rotation.from_euler("xyz", cal.rpy_deg, degrees=True).as_matrix()
    return CameraPose(position, rotation)


def load_calibration(path: Path, frame: str | None = None) -> CameraPose:
    """Read a calibration file (see the module docstring).

    Raises:
        CalibrationError: the file is missing, unreadable, not TOML or invalid (one line).
    """
    hint = "measure the camera's pose in base: docs/kinect_ros1.md#calibration"
    if not path.is_file():
        raise CalibrationError(f"calibration file {path} does not exist ({hint})")
    try:
        table = tomllib.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"calibration file {path} cannot be read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise CalibrationError(f"calibration file {path} is not valid TOML: {exc}") from None
    return parse_calibration(table, f"file {path}", frame)


def solve_camera_pose(points_camera_m: np.ndarray, points_base_m: np.ndarray) -> tuple[CameraPose, np.ndarray]:
    """The camera pose that best maps `points_camera_m` (N, 3) onto `points_base_m` (N, 3)
    (least squares over a rotation and a translation: Kabsch, `Rotation.align_vectors`).

    Returns:
        (pose, residuals (N,) in m: each point's distance after the fit).

    Raises:
        CalibrationError: fewer than 4 pairs, or points on a line (the rotation is undefined).
    """
    cam = np.asarray(points_camera_m, float)
    base = np.asarray(points_base_m, float)
    if cam.ndim != 2 or cam.shape[1] != 3 or cam.shape != base.shape or len(cam) < 4:
        raise CalibrationError(f"need at least 4 point pairs (x, y, z in both frames), got {len(cam)}")
    if not (np.all(np.isfinite(cam)) and np.all(np.isfinite(base))):
        raise CalibrationError("a point pair holds a value that is not a finite number")
    cam_c, base_c = cam - cam.mean(axis=0), base - base.mean(axis=0)
    if np.linalg.svd(cam_c, compute_uv=False)[1] < 0.05 * np.sqrt(len(cam)):
        raise CalibrationError("the points lie (nearly) on a line: spread them over the workspace "
                               "(at least 0.1 m apart in two directions)")
    rotation, _ = Rotation.align_vectors(base_c, cam_c)
    matrix = rotation.as_matrix()
    pose = CameraPose(base.mean(axis=0) - cam.mean(axis=0) @ matrix.T, matrix)
    return pose, np.linalg.norm(pose.to_base(cam) - base, axis=1)


def calibration_text(pose: CameraPose, frame: str, measured: str) -> str:
    """A calibration file's text for `pose` (rpy in degrees, as tf_echo prints)."""
    x, y, z = (float(v) for v in pose.position_m)
    r, p, yaw = (round(v, 3) + 0.0 for v in pose.rpy_deg())  # + 0.0: no "-0.000"
    return (f"# The depth camera's pose in Baxter's base frame (docs/kinect_ros1.md#calibration).\n"
            f"frame = {json.dumps(frame)}\nposition_m = [{x:.4f}, {y:.4f}, {z:.4f}]\n"
            f"rpy_deg = [{r:.3f}, {p:.3f}, {yaw:.3f}]\nmeasured = {json.dumps(measured)}\n")
