"""Baxter's model from the `example-robot-data` package (no network).

Frames: everything is expressed in Baxter's `base` frame (x forward, y left, z up), metres
and radians. The right arm has the seven joints of `RIGHT_ARM_JOINTS`; the tool frame is
`right_gripper`.

This module is shared by the bridge's simulation backend, the motion service, the tracker
and the recorder, so the model is loaded one way everywhere.
"""

from __future__ import annotations

import functools
import os
import sysconfig
from dataclasses import dataclass
from pathlib import Path

import numpy as np

RIGHT_ARM_JOINTS: tuple[str, ...] = (
    "right_s0",
    "right_s1",
    "right_e0",
    "right_e1",
    "right_w0",
    "right_w1",
    "right_w2",
)
TOOL_FRAME = "right_gripper"

#: A comfortable, reachable right-arm posture (rad) used as the sim's start and the
#: retract pose: gripper in front of the robot, about table height.
RIGHT_ARM_HOME_RAD: tuple[float, ...] = (0.0, -0.55, 0.0, 1.28, 0.0, 0.26, 0.0)


class BaxterModelError(Exception):
    """The Baxter model could not be found or loaded (check the example-robot-data install)."""


def _share_dirs() -> list[Path]:
    """Candidate `cmeel.prefix/share` folders, the active environment's first."""
    candidates = []
    for key in ("purelib", "platlib"):
        candidates.append(Path(sysconfig.get_paths()[key]) / "cmeel.prefix" / "share")
    return [c for c in dict.fromkeys(candidates) if c.is_dir()]


@functools.cache
def share_dir() -> Path:
    """The `cmeel.prefix/share` folder that holds example-robot-data.

    Raises:
        BaxterModelError: when the package is not installed in this environment.
    """
    for share in _share_dirs():
        if (share / "example-robot-data").is_dir():
            return share
    raise BaxterModelError(
        "example-robot-data is not installed in this Python environment "
        "(expected <site-packages>/cmeel.prefix/share/example-robot-data); "
        "install the project with `pip install -e .`"
    )


@functools.cache
def urdf_path() -> Path:
    """Absolute path of Baxter's URDF, with ROS_PACKAGE_PATH set so meshes resolve."""
    share = share_dir()
    path = share / "example-robot-data" / "robots" / "baxter_description" / "urdf" / "baxter.urdf"
    if not path.is_file():
        raise BaxterModelError(f"Baxter URDF not found at {path}; reinstall example-robot-data")
    ros_path = os.environ.get("ROS_PACKAGE_PATH", "")
    if str(share) not in ros_path.split(os.pathsep):
        os.environ["ROS_PACKAGE_PATH"] = os.pathsep.join(p for p in (str(share), ros_path) if p)
    return path


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits of the right arm, in `RIGHT_ARM_JOINTS` order.

    Attributes:
        lower_rad, upper_rad: position limits (rad).
        velocity_rad_s: velocity limits (rad/s).
        effort_nm: effort limits (N m).
    """

    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_rad_s: np.ndarray
    effort_nm: np.ndarray


class BaxterArmModel:
    """Pinocchio model of Baxter's right arm: limits and forward kinematics.

    All joints other than the right arm's seven are fixed at zero (neutral). Positions are
    `base`-frame metres.
    """

    def __init__(self) -> None:
        import pinocchio as pin  # imported here: heavy, and only some processes need it

        self._pin = pin
        try:
            full = pin.buildModelFromUrdf(str(urdf_path()))
        except Exception as exc:  # pinocchio raises plain exceptions
            raise BaxterModelError(f"could not parse Baxter URDF: {exc}") from exc
        lock_ids = [
            full.getJointId(name)
            for name in full.names[1:]
            if name not in RIGHT_ARM_JOINTS
        ]
        self.model = pin.buildReducedModel(full, lock_ids, pin.neutral(full))
        self.data = self.model.createData()
        self.joint_names: tuple[str, ...] = tuple(self.model.names[1:])
        if self.joint_names != RIGHT_ARM_JOINTS:
            raise BaxterModelError(f"unexpected Baxter right-arm joints {self.joint_names}")
        if not self.model.existFrame(TOOL_FRAME):
            raise BaxterModelError(f"Baxter URDF has no frame {TOOL_FRAME!r}")
        self.tool_frame_id = self.model.getFrameId(TOOL_FRAME)
        self.limits = JointLimits(
            lower_rad=np.array(self.model.lowerPositionLimit, dtype=float),
            upper_rad=np.array(self.model.upperPositionLimit, dtype=float),
            velocity_rad_s=np.array(self.model.velocityLimit, dtype=float),
            effort_nm=np.array(self.model.effortLimit, dtype=float),
        )

    def tool_pose(self, q_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the tool frame.

        Args:
            q_rad: right-arm joint positions (7,), rad.

        Returns:
            (position_m (3,), rotation (3, 3)) of `right_gripper` in the `base` frame.
        """
        pin = self._pin
        q = np.asarray(q_rad, dtype=float)
        pin.framesForwardKinematics(self.model, self.data, q)
        placement = self.data.oMf[self.tool_frame_id]
        return placement.translation.copy(), placement.rotation.copy()

    def frame_positions(self, q_rad: np.ndarray, frame_names: list[str]) -> np.ndarray:
        """Positions (N, 3) in metres of the named frames in the `base` frame."""
        pin = self._pin
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q_rad, dtype=float))
        return np.array(
            [self.data.oMf[self.model.getFrameId(name)].translation for name in frame_names]
        )


@functools.cache
def arm_model() -> BaxterArmModel:
    """A process-wide cached `BaxterArmModel` (loading takes a few ms)."""
    return BaxterArmModel()
