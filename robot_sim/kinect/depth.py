"""Depth rendering of the scene as a Kinect v1 sees it (numpy ray casting).

Each primitive is intersected only with the rays inside its projected bounding rectangle,
so a frame costs a few milliseconds. Depths are z along the optical axis (metres).

Noise model (Khoshelham & Elberink 2012, "Accuracy and resolution of Kinect depth data"):
random error σ_z = 1.425e-3 · z² (m), then the disparity is quantised to 1/8 pixel, which
gives Kinect v1's depth steps (≈ 1 cm at 2 m), then depths are rounded to millimetres.
Pixels outside the 0.5–4.5 m range read 0 (no reading), and a small random fraction of
pixels drops out.
"""

from __future__ import annotations

import numpy as np

from robot_sim.kinect import camera as cam
from robot_sim.kinect.camera import KinectCamera
from robot_sim.kinect.shapes import Box, Capsule, ray_box, ray_capsule, ray_horizontal_plane

#: Random depth error coefficient (m⁻¹): σ_z = coefficient · z².
DEPTH_NOISE_COEFF_PER_M = 1.425e-3


class DepthRenderer:
    """Ray-casts capsules, boxes and the floor into a depth image.

    Args:
        camera: the camera (pose and intrinsics).
    """

    def __init__(self, camera: KinectCamera) -> None:
        self.camera = camera
        self.rays = camera.rays_base()
        self._h, self._w = camera.height_px, camera.width_px

    def _rect(self, points_m: np.ndarray, radius_m: float) -> tuple[int, int, int, int] | None:
        """Pixel rectangle (u0, u1, v0, v1) that holds the projection of spheres of
        `radius_m` around `points_m`; None when nothing can be visible."""
        c = self.camera
        uv, z = c.project(points_m)
        if np.all(z <= 0.0):
            return None
        if np.any(z <= 0.05):
            return 0, self._w, 0, self._h
        pad = 1.3 * radius_m * c.fx_px / z + 2.0
        u0 = int(np.floor(np.min(uv[:, 0] - pad)))
        u1 = int(np.ceil(np.max(uv[:, 0] + pad))) + 1
        v0 = int(np.floor(np.min(uv[:, 1] - pad)))
        v1 = int(np.ceil(np.max(uv[:, 1] + pad))) + 1
        u0, v0 = max(u0, 0), max(v0, 0)
        u1, v1 = min(u1, self._w), min(v1, self._h)
        if u0 >= u1 or v0 >= v1:
            return None
        return u0, u1, v0, v1

    def render(
        self,
        capsules: list[Capsule],
        boxes: list[Box] = (),
        floor_z_m: float | None = None,
    ) -> np.ndarray:
        """Noise-free depth (H, W) in metres, +inf where nothing is hit."""
        origin = self.camera.position_m
        if floor_z_m is not None:
            depth = ray_horizontal_plane(origin, self.rays, floor_z_m)
        else:
            depth = np.full((self._h, self._w), np.inf)
        for capsule in capsules:
            rect = self._rect(np.stack([capsule.a_m, capsule.b_m]), capsule.radius_m)
            if rect is None:
                continue
            u0, u1, v0, v1 = rect
            t = ray_capsule(origin, self.rays[v0:v1, u0:u1], capsule)
            np.minimum(depth[v0:v1, u0:u1], t, out=depth[v0:v1, u0:u1])
        for box in boxes:
            lo, hi = np.asarray(box.lower_m, float), np.asarray(box.upper_m, float)
            corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
            rect = self._rect(corners, 0.0)
            if rect is None:
                continue
            u0, u1, v0, v1 = rect
            t = ray_box(origin, self.rays[v0:v1, u0:u1], box)
            np.minimum(depth[v0:v1, u0:u1], t, out=depth[v0:v1, u0:u1])
        return depth


def kinect_depth_mm(
    depth_m: np.ndarray,
    rng: np.random.Generator | None,
    dropout_fraction: float = 0.005,
) -> np.ndarray:
    """Turn an ideal depth image (m, inf = no hit) into Kinect v1 readings (uint16 mm).

    Args:
        depth_m: ideal depths.
        rng: random generator for noise and dropouts; None gives the quantised, noise-free
            image (for tests).
        dropout_fraction: fraction of pixels with no reading.
    """
    z = np.array(depth_m, dtype=float)
    valid = np.isfinite(z) & (z >= cam.KINECT_MIN_RANGE_M) & (z <= cam.KINECT_MAX_RANGE_M)
    zv = np.where(valid, z, 1.0)
    if rng is not None:
        zv = zv + rng.standard_normal(z.shape) * DEPTH_NOISE_COEFF_PER_M * zv * zv
        zv = np.maximum(zv, 1e-3)
    fb = cam.KINECT_FULL_RES_FOCAL_PX * cam.KINECT_BASELINE_M
    disparity = np.round(fb / zv / cam.KINECT_DISPARITY_STEP_PX) * cam.KINECT_DISPARITY_STEP_PX
    zq = fb / np.maximum(disparity, cam.KINECT_DISPARITY_STEP_PX)
    mm = np.round(zq * 1000.0)
    if rng is not None and dropout_fraction > 0.0:
        valid &= rng.random(z.shape) >= dropout_fraction
    valid &= (zq >= cam.KINECT_MIN_RANGE_M) & (zq <= cam.KINECT_MAX_RANGE_M)
    return np.where(valid, mm, 0).astype(np.uint16)
