"""The robot arm as capsules along its link frames, from the joint state.

Used by the simulated Kinect to draw the robot into the depth image and by the tracker to
remove the robot's own points from the cloud, so both agree on the same geometry. Positions
come from pinocchio forward kinematics of the arm's model (`handover_model.robots.arm_model`,
`base` frame, metres). The capsules are the description's (`RobotDescription.capsules`), or one
per link of the chain with `link_radius_m`; its fixed parts (a torso, a pedestal) are
`body_capsules`.
"""

from __future__ import annotations

import numpy as np

from handover_model import robots
from handover_model.robots import ArmModel, RobotDescription
from handover_model.shapes import Capsule


def body_capsules(desc: RobotDescription | None = None) -> tuple[Capsule, ...]:
    """The arm's fixed parts (torso, pedestal) as capsules in `base`, metres."""
    desc = desc or robots.active()
    return tuple(Capsule(np.array(a, dtype=float), np.array(b, dtype=float), r) for a, b, r in desc.body_capsules)


def link_capsules(model: ArmModel) -> tuple[tuple[str, str, float], ...]:
    """(from frame, to frame, radius m) of each drawn link: the description's, or one per link
    of the chain (each joint's child link to the next, the last to the tool frame)."""
    desc = model.description
    if desc.capsules:
        return tuple((c.frame_a, c.frame_b, c.radius_m) for c in desc.capsules)
    frames = model.chain_frames()
    return tuple((a, b, desc.link_radius_m) for a, b in zip(frames[:-1], frames[1:]))


class ArmGeometry:
    """Capsules of the arm for a joint configuration.

    Args:
        model: the arm's model (defaults to the active arm's, process-wide).
    """

    def __init__(self, model: ArmModel | None = None) -> None:
        self.model = model or robots.arm_model()
        self.link_capsules = link_capsules(self.model)
        self.body_capsules = body_capsules(self.model.description)
        names = sorted({n for a, b, _ in self.link_capsules for n in (a, b)})
        self._frame_names = names
        self._index = {n: i for i, n in enumerate(names)}

    def frame_positions(self, q_rad: np.ndarray) -> dict[str, np.ndarray]:
        """Positions (m, `base`) of the link frames used by the capsules."""
        pos = self.model.frame_positions(np.asarray(q_rad, float), self._frame_names)
        return {n: pos[i] for n, i in self._index.items()}

    def capsules(self, q_rad: np.ndarray, include_torso: bool = True) -> list[Capsule]:
        """Capsules of the arm (and its fixed parts with `include_torso`) at `q_rad`, rad."""
        pos = self.frame_positions(q_rad)
        caps = [Capsule(pos[a], pos[b], r) for a, b, r in self.link_capsules]
        if include_torso:
            caps.extend(self.body_capsules)
        return caps

    def tool_position(self, q_rad: np.ndarray) -> np.ndarray:
        """Tool position (3,), m, `base` (between the fingertips)."""
        return self.model.tool_pose(np.asarray(q_rad, float))[0]
