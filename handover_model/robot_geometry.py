"""Baxter's right arm as capsules along its link frames, from the joint state.

Used by the simulated Kinect to draw the robot into the depth image and by the tracker to
remove the robot's own points from the cloud, so both agree on the same geometry. Positions
come from pinocchio forward kinematics of `handover_model.baxter.arm_model()` (`base` frame,
metres). The torso is a fixed capsule; the left arm is not drawn.
"""

from __future__ import annotations

import numpy as np

from handover_model.baxter import TOOL_FRAME, BaxterArmModel, arm_model
from handover_model.shapes import Capsule

#: (from frame, to frame, radius m): the right arm's links, shoulder to fingertips.
ARM_LINK_CAPSULES: tuple[tuple[str, str, float], ...] = (
    ("right_upper_shoulder", "right_lower_shoulder", 0.075),
    ("right_lower_shoulder", "right_upper_elbow", 0.070),
    ("right_upper_elbow", "right_lower_elbow", 0.065),
    ("right_lower_elbow", "right_upper_forearm", 0.060),
    ("right_upper_forearm", "right_lower_forearm", 0.055),
    ("right_lower_forearm", "right_wrist", 0.050),
    ("right_wrist", "right_gripper_base_link", 0.050),
    ("right_gripper_base_link", TOOL_FRAME, 0.035),
)
#: Baxter's torso as a fixed capsule in `base` (a, b, radius), metres. The head is not
#: drawn: the Kinect is mounted above it (`robot_sim.kinect.camera`).
TORSO_CAPSULES: tuple[Capsule, ...] = (
    Capsule(np.array([0.0, 0.0, -0.35]), np.array([0.0, 0.0, 0.30]), 0.17),
)


class ArmGeometry:
    """Capsules of the right arm for a joint configuration.

    Args:
        model: the Baxter arm model (defaults to the process-wide one).
    """

    def __init__(self, model: BaxterArmModel | None = None) -> None:
        self.model = model or arm_model()
        names = sorted({n for a, b, _ in ARM_LINK_CAPSULES for n in (a, b)})
        self._frame_names = names
        self._index = {n: i for i, n in enumerate(names)}

    def frame_positions(self, q_rad: np.ndarray) -> dict[str, np.ndarray]:
        """Positions (m, `base`) of the link frames used by the capsules."""
        pos = self.model.frame_positions(np.asarray(q_rad, float), self._frame_names)
        return {n: pos[i] for n, i in self._index.items()}

    def capsules(self, q_rad: np.ndarray, include_torso: bool = True) -> list[Capsule]:
        """Capsules of the arm (and Baxter's torso) at `q_rad` (7,), rad."""
        pos = self.frame_positions(q_rad)
        caps = [Capsule(pos[a], pos[b], r) for a, b, r in ARM_LINK_CAPSULES]
        if include_torso:
            caps.extend(TORSO_CAPSULES)
        return caps

    def tool_position(self, q_rad: np.ndarray) -> np.ndarray:
        """Tool (`right_gripper`, between the fingertips) position (3,), m, `base`."""
        return self.model.tool_pose(np.asarray(q_rad, float))[0]
