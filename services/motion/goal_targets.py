"""What a `MotionGoal` asks for, checked: the tool position, the tool rotation, the joint target.

Pure functions of the goal's fields (and the limits they must respect); each raises
`GoalRejected` with a reason the status reports word for word.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from bus_schema.messages import MotionGoal
from handover_model import robots
from services.motion.config import MotionConfig
from services.motion.errors import GoalRejected
from services.motion.ik import UPRIGHT_ROTATION

#: A goal's quaternion may differ from unit norm by this much (it is then normalised).
UNIT_QUATERNION_TOLERANCE = 1e-3


def goal_rotation(goal: MotionGoal) -> np.ndarray:
    """The tool rotation (3, 3) the goal asks for, in the `base` frame: upright when the goal
    gives no `orientation_xyzw`.

    Raises:
        GoalRejected: the quaternion is not of unit norm.
    """
    if goal.orientation_xyzw is None:
        return UPRIGHT_ROTATION
    quat = np.array(goal.orientation_xyzw, dtype=float)
    norm = float(np.linalg.norm(quat))
    if abs(norm - 1.0) > UNIT_QUATERNION_TOLERANCE:
        raise GoalRejected(f"orientation_xyzw is not a unit quaternion (norm {norm:.4f})")
    return Rotation.from_quat(quat / norm).as_matrix()


def goal_position_m(goal: MotionGoal, config: MotionConfig) -> np.ndarray:
    """The tool position (3,) the goal asks for, m, `base` frame.

    Raises:
        GoalRejected: the goal has no `position_base_m`, or it lies outside the workspace box
            (`config.workspace_min_m` .. `workspace_max_m`).
    """
    if goal.position_base_m is None:
        raise GoalRejected(f"a {goal.kind} goal needs position_base_m")
    p = np.array(goal.position_base_m, dtype=float)
    lo = np.array(config.workspace_min_m)
    hi = np.array(config.workspace_max_m)
    outside = [
        f"{axis}={p[i]:.3f} not in [{lo[i]:.2f}, {hi[i]:.2f}]"
        for i, axis in enumerate("xyz")
        if not lo[i] <= p[i] <= hi[i]
    ]
    if outside:
        raise GoalRejected("goal outside the workspace: " + ", ".join(outside) + " m (base frame)")
    return p


def goal_joint_target_rad(goal: MotionGoal, lower_rad: np.ndarray, upper_rad: np.ndarray,
                          joint_names: Sequence[str] | None = None) -> np.ndarray | None:
    """The arm's joint target (n,), rad, or None when the goal gives none.

    Raises:
        GoalRejected: not one value per joint of `joint_names`, or a value outside
            [`lower_rad`, `upper_rad`]. `joint_names`: the arm's joints (default: the active arm's).
    """
    if not goal.joint_target_rad:
        return None
    joint_names = tuple(joint_names or robots.active().joints)
    if len(goal.joint_target_rad) != len(joint_names):
        raise GoalRejected(
            f"joint_target_rad needs {len(joint_names)} values ({joint_names[0]}..{joint_names[-1]}), "
            f"got {len(goal.joint_target_rad)}"
        )
    q = np.array(goal.joint_target_rad, dtype=float)
    outside = (q < lower_rad) | (q > upper_rad)
    if outside.any():
        names = [joint_names[i] for i in np.flatnonzero(outside)]
        raise GoalRejected(f"joint_target_rad outside the joint limits at {names}")
    return q
