"""``handover-tracker calibrate-kinect``: the ROS 1 camera's pose in `base` from point pairs.

Each line of the CSV is one point seen in both frames: where the camera puts it
(``openni_depth_frame``, m: e.g. the marker on the gripper read off the depth cloud) and where
the robot puts it (`base`, m: the gripper's tool point from its joint states). At least 4
points spread over the workspace; docs/kinect_ros1.md#calibration gives the procedure.
"""

from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np

from services.tracker.errors import CalibrationError
from services.tracker.ros1.calibration import calibration_text, solve_camera_pose

#: A residual above this says a point was misread (or the rig moved), m.
RESIDUAL_WARNING_M = 0.02


def read_pairs(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(camera points (N, 3), base points (N, 3)), m, from the CSV at `path`.

    Raises:
        CalibrationError: missing file, not 6 numbers a line.
    """
    if not path.is_file():
        raise CalibrationError(f"point pairs file {path} does not exist")
    try:
        rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=float)
    except (ValueError, OSError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"point pairs file {path}: {exc}") from None
    if rows.shape[1] != 6:
        raise CalibrationError(f"point pairs file {path}: {rows.shape[1]} columns, need 6 "
                               "(camera_x,camera_y,camera_z,base_x,base_y,base_z)")
    return rows[:, :3], rows[:, 3:]


def calibrate(pairs: Path, output: Path, frame: str, force: bool) -> int:
    """Solve, print the pose and each point's residual, write `output`. Exit code 0."""
    if output.exists() and not force:
        raise CalibrationError(f"{output} exists: pass --force to overwrite it")
    camera, base = read_pairs(pairs)
    pose, residuals = solve_camera_pose(camera, base)
    x, y, z = pose.position_m
    r, p, yaw = pose.rpy_deg()
    print(f"camera ({frame}) in base: position {x:+.4f} {y:+.4f} {z:+.4f} m, rpy {r:+.2f} {p:+.2f} {yaw:+.2f} deg")
    print(f"residuals over {len(residuals)} points: rms {np.sqrt(np.mean(residuals ** 2)) * 1e3:.1f} mm, "
          f"max {residuals.max() * 1e3:.1f} mm (point {int(residuals.argmax()) + 1})")
    if residuals.max() > RESIDUAL_WARNING_M:
        print(f"warning: point {int(residuals.argmax()) + 1} is {residuals.max() * 1e3:.0f} mm off: re-measure it "
              "or leave it out")
    stamp = datetime.datetime.now().isoformat(timespec="seconds")
    output.write_text(calibration_text(pose, frame, f"{stamp}: {len(residuals)} point pairs from {pairs.name}, "
                                                    f"rms {np.sqrt(np.mean(residuals ** 2)) * 1e3:.1f} mm"))
    print(f"wrote {output}")
    return 0
