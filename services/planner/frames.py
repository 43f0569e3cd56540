"""Task plane ↔ scene `base` frame.

The task plane (thesis §2.2, Fig. 2) is a vertical plane: origin at the middle of the table
top, x from the giver (the robot) toward the receiver, z up. It is placed in `base` (x forward,
y left, z up, metres) by two configurable quantities:

- `origin_base_m`: the task-plane origin in `base`;
- `x_axis_base_xy`: the direction of the task-plane x axis in the horizontal plane of `base`
  (normalised here); the task z axis is `base` z.

A task point (x, z) is the `base` point ``origin + x·(ax, ay, 0) + z·(0, 0, 1)``. The defaults
come from `handover_model.scene`: the robot stands at the table facing the receiver, the plane runs
along `base` +x through the giver's shoulder (y = scene.TASK_PLANE_Y_M), and its origin is
half the actor separation in front of that shoulder, on the table top.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handover_model import scene
from services.planner.errors import PlannerError

DEFAULT_ORIGIN_BASE_M = (scene.TASK_ORIGIN_X_M, scene.TASK_PLANE_Y_M, scene.TABLE_TOP_Z_M)
DEFAULT_X_AXIS_BASE_XY = (1.0, 0.0)


@dataclass(frozen=True)
class TaskPlaneFrame:
    """Placement of the task plane in `base`.

    Attributes:
        origin_base_m: task-plane origin (middle of the table top) in `base`, m.
        x_axis_base_xy: horizontal direction of the task x axis in `base` (any length > 0).
    """

    origin_base_m: tuple[float, float, float] = DEFAULT_ORIGIN_BASE_M
    x_axis_base_xy: tuple[float, float] = DEFAULT_X_AXIS_BASE_XY

    def __post_init__(self) -> None:
        origin = np.asarray(self.origin_base_m, dtype=float)
        axis = np.asarray(self.x_axis_base_xy, dtype=float)
        if origin.shape != (3,) or not np.all(np.isfinite(origin)):
            raise PlannerError(f"task-plane origin {self.origin_base_m!r} must be 3 finite numbers (m)")
        if axis.shape != (2,) or not np.all(np.isfinite(axis)) or np.hypot(*axis) < 1e-9:
            raise PlannerError(
                f"task-plane x axis {self.x_axis_base_xy!r} must be a non-zero horizontal direction (ax, ay)"
            )

    @property
    def x_axis_base(self) -> np.ndarray:
        """Unit task x axis in `base` (3,)."""
        ax, ay = np.asarray(self.x_axis_base_xy, dtype=float) / np.hypot(*self.x_axis_base_xy)
        return np.array([ax, ay, 0.0])

    def task_to_base(self, point_task_m: np.ndarray) -> np.ndarray:
        """Task-plane points (..., 2) = (x, z) → `base` points (..., 3), m."""
        p = np.asarray(point_task_m, dtype=float)
        ex = self.x_axis_base
        return (
            np.asarray(self.origin_base_m)
            + p[..., 0:1] * ex
            + p[..., 1:2] * np.array([0.0, 0.0, 1.0])
        )

    def base_to_task(self, point_base_m: np.ndarray) -> np.ndarray:
        """`base` points (..., 3) → their projection on the task plane (..., 2), m."""
        d = np.asarray(point_base_m, dtype=float) - np.asarray(self.origin_base_m)
        return np.stack([d @ self.x_axis_base, d[..., 2]], axis=-1)

    def offset_from_plane_m(self, point_base_m: np.ndarray) -> np.ndarray:
        """Signed horizontal distance of `base` points from the plane (left of +x positive), m."""
        d = np.asarray(point_base_m, dtype=float) - np.asarray(self.origin_base_m)
        ex = self.x_axis_base
        ey = np.array([-ex[1], ex[0], 0.0])
        return d @ ey
