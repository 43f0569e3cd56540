"""The shared scene: where the table, the task plane and the receiver are.

Every service that needs the geometry of the handover scene reads it from here, so that the
simulator, the tracker, the planner and the motion service agree.

Frames:
- `base`: the scene's frame (x forward, y left, z up): the default arm's base frame, origin at
  its torso centre, `BASE_HEIGHT_ABOVE_FLOOR_M` above the floor (its standard pedestal). Every
  other arm's base is placed in it (`handover_model.robots.RobotDescription.base_xyz_m`).
- task plane (thesis §2.2, Fig. 2): the vertical plane through giver, receiver and the
  transfer point. Its origin is the middle of the table top; its x axis points from the
  giver (the robot) to the receiver, and is the scene's +x; its z axis is up. The plane is the
  x–z plane of `base` at y = `TASK_PLANE_Y_M` (through the giver's shoulder), so a task
  point (x, z) is the base point (TASK_ORIGIN_X_M + x, TASK_PLANE_Y_M, TABLE_TOP_Z_M + z).

Layout (thesis Fig. 2): actors 100 cm apart across a table 60 cm deep and 70 cm high; the
giver's and the receiver's shoulders lie in the task plane, ±50 cm from its origin along x.
The receiver faces the robot (−x) and receives with the right hand, whose shoulder is in the
task plane; the receiver's torso is therefore offset toward −y by half a shoulder width.
"""

from __future__ import annotations

import numpy as np

BASE_HEIGHT_ABOVE_FLOOR_M = 0.93
TABLE_HEIGHT_M = 0.70
TABLE_DEPTH_M = 0.60
TABLE_WIDTH_M = 0.75
ACTOR_SEPARATION_M = 1.00

#: The giver's shoulder in `base`: the default arm's right shoulder (right_upper_shoulder
#: frame, from its URDF); every other arm is placed in this scene (`handover_model.robots`).
ROBOT_RIGHT_SHOULDER_BASE_M = np.array([0.064, -0.259, 0.130])

TASK_PLANE_Y_M = float(ROBOT_RIGHT_SHOULDER_BASE_M[1])
TABLE_TOP_Z_M = TABLE_HEIGHT_M - BASE_HEIGHT_ABOVE_FLOOR_M
#: The giver's shoulder is half the actor separation behind the task-plane origin.
TASK_ORIGIN_X_M = float(ROBOT_RIGHT_SHOULDER_BASE_M[0]) + ACTOR_SEPARATION_M / 2.0

#: Table centre (top surface) in `base`.
TABLE_TOP_CENTRE_BASE_M = np.array([TASK_ORIGIN_X_M, TASK_PLANE_Y_M, TABLE_TOP_Z_M])
#: Receiver's receiving (right) shoulder lies in the task plane, across the table.
RECEIVER_SHOULDER_X_BASE_M = TASK_ORIGIN_X_M + ACTOR_SEPARATION_M / 2.0
#: Receiver's half shoulder width (m): its torso centre is this far on −y of the shoulder.
RECEIVER_HALF_SHOULDER_WIDTH_M = 0.19
RECEIVER_TORSO_BASE_XY_M = np.array(
    [RECEIVER_SHOULDER_X_BASE_M, TASK_PLANE_Y_M - RECEIVER_HALF_SHOULDER_WIDTH_M]
)
#: Where the object waits on the table for the pick (base frame, object centre on the top).
OBJECT_PICK_BASE_M = np.array([0.72, -0.55, TABLE_TOP_Z_M + 0.06])


def task_to_base(point_task_m: np.ndarray) -> np.ndarray:
    """Map task-plane points (..., 2) = (x, z) to `base` points (..., 3), metres."""
    p = np.asarray(point_task_m, dtype=float)
    out = np.empty(p.shape[:-1] + (3,))
    out[..., 0] = TASK_ORIGIN_X_M + p[..., 0]
    out[..., 1] = TASK_PLANE_Y_M
    out[..., 2] = TABLE_TOP_Z_M + p[..., 1]
    return out


def base_to_task(point_base_m: np.ndarray) -> np.ndarray:
    """Project `base` points (..., 3) onto the task plane, returning (..., 2) = (x, z)."""
    p = np.asarray(point_base_m, dtype=float)
    return np.stack([p[..., 0] - TASK_ORIGIN_X_M, p[..., 2] - TABLE_TOP_Z_M], axis=-1)
