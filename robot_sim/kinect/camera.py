"""Where the simulated Kinect sits and how it projects.

The one documented place for the sensor's pose (the rest of the scene is in
`handover_model.scene`). Frames:

- `base`: the scene's base frame (x forward, y left, z up), metres.
- optical frame of the camera: z forward along the optical axis, x right, y down (the
  convention of `bus_schema.messages.DepthImage`).

Placement: the Kinect is mounted above the robot's base (on the default arm's head, a common set-up), 0.95 m
above the base origin (1.88 m above the floor), looking down across the table at the
receiver. From there it sees the receiver's front from the head down to the thighs, the
table top, the object on it and the robot's right arm from behind and above, so the robot's
gripper can come between the sensor and the receiver's hand during the final approach, as in
Mincelli et al.'s set-up. The head is behind the sensor and is not drawn.

Intrinsics: Kinect v1 depth camera binned to 320x240 (57° x 43° field of view,
f ≈ 285 px). Depth is measured along the optical axis (the z coordinate), not along the ray.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from handover_model import scene

#: Kinect v1 depth-image size after 2x binning (px).
KINECT_WIDTH_PX = 320
KINECT_HEIGHT_PX = 240
#: Focal length (px) at 320x240: the full-resolution 571 px halved.
KINECT_FOCAL_PX = 285.5
#: Working range of the Kinect v1 depth sensor (m); outside it the pixel reads 0.
KINECT_MIN_RANGE_M = 0.5
KINECT_MAX_RANGE_M = 4.5
#: Baseline between the IR projector and camera (m) and the full-resolution focal length
#: (px); with 1/8-pixel disparity steps they give Kinect v1's depth quantisation.
KINECT_BASELINE_M = 0.075
KINECT_FULL_RES_FOCAL_PX = 571.0
KINECT_DISPARITY_STEP_PX = 1.0 / 8.0

#: Sensor position in `base` (m): on top of the default arm's head.
KINECT_POSITION_BASE_M = np.array([0.10, 0.0, 0.95])
#: The point the optical axis passes through (m, `base`): the receiver's torso, 23 cm above
#: the table top.
KINECT_LOOK_AT_BASE_M = np.array(
    [scene.RECEIVER_SHOULDER_X_BASE_M - 0.06, scene.RECEIVER_TORSO_BASE_XY_M[1] + 0.10, scene.TABLE_TOP_Z_M + 0.23]
)


def look_at_rotation(position_m: np.ndarray, target_m: np.ndarray) -> np.ndarray:
    """Rotation (3, 3) from the optical frame to `base` for a camera at `position_m`
    looking at `target_m`, with the image's up direction as close to `base` +z as possible."""
    forward = np.asarray(target_m, float) - np.asarray(position_m, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.array([0.0, 0.0, 1.0]))
    norm = np.linalg.norm(right)
    if norm < 1e-9:
        raise ValueError("camera looks straight up or down: the image's x axis is undefined")
    right /= norm
    down = np.cross(forward, right)
    return np.column_stack([right, down, forward])


@dataclass(frozen=True)
class KinectCamera:
    """Pinhole depth camera.

    Attributes:
        width_px, height_px: image size.
        fx_px, fy_px, cx_px, cy_px: intrinsics (px); pixel (u, v) looks along
            ((u - cx)/fx, (v - cy)/fy, 1) in the optical frame.
        position_m: optical centre in `base` (m).
        rotation: (3, 3) rotation from the optical frame to `base`.
    """

    width_px: int = KINECT_WIDTH_PX
    height_px: int = KINECT_HEIGHT_PX
    fx_px: float = KINECT_FOCAL_PX
    fy_px: float = KINECT_FOCAL_PX
    cx_px: float = (KINECT_WIDTH_PX - 1) / 2.0
    cy_px: float = (KINECT_HEIGHT_PX - 1) / 2.0
    position_m: np.ndarray = field(default_factory=lambda: KINECT_POSITION_BASE_M.copy())
    rotation: np.ndarray = field(
        default_factory=lambda: look_at_rotation(KINECT_POSITION_BASE_M, KINECT_LOOK_AT_BASE_M)
    )

    @property
    def orientation_xyzw(self) -> tuple[float, float, float, float]:
        """Orientation of the optical frame in `base` as a unit quaternion (x, y, z, w)."""
        q = Rotation.from_matrix(self.rotation).as_quat()
        if q[3] < 0:
            q = -q
        x, y, z, w = (float(c) for c in q)
        return x, y, z, w

    def rays_optical(self) -> np.ndarray:
        """Per-pixel ray directions (H, W, 3) in the optical frame, scaled so z = 1."""
        u = (np.arange(self.width_px) - self.cx_px) / self.fx_px
        v = (np.arange(self.height_px) - self.cy_px) / self.fy_px
        rays = np.empty((self.height_px, self.width_px, 3))
        rays[..., 0] = u[None, :]
        rays[..., 1] = v[:, None]
        rays[..., 2] = 1.0
        return rays

    def rays_base(self) -> np.ndarray:
        """Per-pixel ray directions (H, W, 3) in `base`; the ray parameter is the z depth."""
        return self.rays_optical() @ self.rotation.T

    def project(self, points_base_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project `base` points (N, 3) to pixels.

        Returns:
            (uv (N, 2) pixel coordinates, z_m (N,) depth along the optical axis).
        """
        p = (np.asarray(points_base_m, float) - self.position_m) @ self.rotation
        z = p[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack(
                [self.fx_px * p[:, 0] / z + self.cx_px, self.fy_px * p[:, 1] / z + self.cy_px],
                axis=1,
            )
        return uv, z
