"""An arm's pinocchio model: joint limits and forward kinematics in the scene frame `base`.

Every joint other than the description's chain is locked at zero. Positions are `base`-frame
metres; the model is built from `urdf.model_urdf_text` (the arm placed in `base`, the tool frame
added), so forward kinematics answer in `base` for every arm.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from handover_model.robots.description import RobotDescription, RobotDescriptionError
from handover_model.robots.urdf import model_urdf_text


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits of the arm, in the description's `joints` order.

    Attributes:
        lower_rad, upper_rad: position limits (rad).
        velocity_rad_s: velocity limits (rad/s): the description's, else the URDF's.
        effort_nm: effort limits (N m).
    """

    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity_rad_s: np.ndarray
    effort_nm: np.ndarray


class ArmModel:
    """Pinocchio model of one arm (see the module docstring).

    Raises:
        RobotDescriptionError: the URDF does not parse, lacks a joint of the chain or the tool frame.
    """

    def __init__(self, desc: RobotDescription) -> None:
        import pinocchio as pin  # imported here: heavy, and only some processes need it

        self._pin = pin
        self.description = desc
        try:
            full = pin.buildModelFromXML(model_urdf_text(desc))
        except Exception as exc:  # pinocchio raises plain exceptions
            raise RobotDescriptionError(f"could not parse {desc.name}'s URDF: {exc}") from exc
        missing = [j for j in desc.joints if not full.existJointName(j)]
        if missing:
            raise RobotDescriptionError(f"robot {desc.name!r}: joints {missing} are not in its URDF")
        lock_ids = [full.getJointId(name) for name in full.names[1:] if name not in desc.joints]
        self.model = pin.buildReducedModel(full, lock_ids, pin.neutral(full))
        self.data = self.model.createData()
        self.joint_names: tuple[str, ...] = tuple(self.model.names[1:])
        if self.joint_names != desc.joints:
            raise RobotDescriptionError(f"robot {desc.name!r}: its URDF orders the chain {self.joint_names}, "
                                        f"the description {desc.joints}")
        if not self.model.existFrame(desc.tool_frame):
            raise RobotDescriptionError(f"robot {desc.name!r}: its URDF has no frame {desc.tool_frame!r}")
        self.tool_frame_id = self.model.getFrameId(desc.tool_frame)
        urdf_velocity = np.array(self.model.velocityLimit, dtype=float)
        velocity = np.array(desc.velocity_rad_s, dtype=float) if desc.velocity_rad_s else urdf_velocity
        self.limits = JointLimits(
            lower_rad=np.array(self.model.lowerPositionLimit, dtype=float),
            upper_rad=np.array(self.model.upperPositionLimit, dtype=float),
            velocity_rad_s=velocity,
            effort_nm=np.array(self.model.effortLimit, dtype=float),
        )

    def tool_pose(self, q_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics of the tool frame: (position_m (3,), rotation (3, 3)) in `base`."""
        pin = self._pin
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q_rad, dtype=float))
        placement = self.data.oMf[self.tool_frame_id]
        return placement.translation.copy(), placement.rotation.copy()

    def frame_positions(self, q_rad: np.ndarray, frame_names: list[str]) -> np.ndarray:
        """Positions (N, 3) in metres of the named frames in `base`."""
        pin = self._pin
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q_rad, dtype=float))
        return np.array([self.data.oMf[self.model.getFrameId(name)].translation for name in frame_names])

    def chain_frames(self) -> list[str]:
        """The child link of each chain joint, then the tool frame (for automatic capsules)."""
        names = []
        for joint_id in range(1, self.model.njoints):
            for frame in self.model.frames:
                if frame.parentJoint == joint_id and frame.type == self._pin.FrameType.BODY:
                    names.append(frame.name)
                    break
        return names + [self.description.tool_frame]


@functools.cache
def arm_model_of(desc: RobotDescription) -> ArmModel:
    """A process-wide cached `ArmModel` of `desc` (loading takes a few ms)."""
    return ArmModel(desc)
