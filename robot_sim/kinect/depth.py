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

import math

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
        self._dd = np.einsum("...i,...i->...", self.rays, self.rays)
        self._h, self._w = camera.height_px, camera.width_px

    def _rect(self, uv: list[list[float]], z: list[float], radius_m: float) -> tuple[int, int, int, int] | None:
        """Pixel rectangle (u0, u1, v0, v1) that holds the projection of spheres of
        `radius_m` around points projected to `uv` (pixels) at depths `z` (m); None when
        nothing can be visible."""
        if max(z) <= 0.0:
            return None
        if min(z) <= 0.05:
            return 0, self._w, 0, self._h
        fx = self.camera.fx_px
        pads = [1.3 * radius_m * fx / zi + 2.0 for zi in z]
        u0 = max(math.floor(min(p[0] - d for p, d in zip(uv, pads, strict=True))), 0)
        u1 = min(math.ceil(max(p[0] + d for p, d in zip(uv, pads, strict=True))) + 1, self._w)
        v0 = max(math.floor(min(p[1] - d for p, d in zip(uv, pads, strict=True))), 0)
        v1 = min(math.ceil(max(p[1] + d for p, d in zip(uv, pads, strict=True))) + 1, self._h)
        if u0 >= u1 or v0 >= v1:
            return None
        return u0, u1, v0, v1

    def render(
        self,
        capsules: list[Capsule],
        boxes: list[Box] = (),
        floor_z_m: float | None = None,
        background: np.ndarray | None = None,
    ) -> np.ndarray:
        """Noise-free depth (H, W) in metres, +inf where nothing is hit.

        Args:
            capsules, boxes: the primitives (m, `base`).
            floor_z_m: height of a horizontal floor plane (m, `base`), None for none.
            background: a depth image of parts that do not move (a `render` of them), drawn
                behind the primitives: the static scene is cast once, not every frame.
        """
        origin = self.camera.position_m
        if background is not None:
            if background.shape != (self._h, self._w):
                raise ValueError(f"background is {background.shape}, the camera is {(self._h, self._w)}")
            depth = background.copy()
        else:
            depth = np.full((self._h, self._w), np.inf)
        if floor_z_m is not None:
            np.minimum(depth, ray_horizontal_plane(origin, self.rays, floor_z_m), out=depth)
        if capsules:
            ends = np.array([(c.a_m, c.b_m) for c in capsules], float).reshape(-1, 3)
            uv, z = self.camera.project(ends)
            uv_l, z_l = uv.tolist(), z.tolist()
            for i, capsule in enumerate(capsules):
                rect = self._rect(uv_l[2 * i:2 * i + 2], z_l[2 * i:2 * i + 2], capsule.radius_m)
                if rect is None:
                    continue
                u0, u1, v0, v1 = rect
                t = ray_capsule(origin, self.rays[v0:v1, u0:u1], capsule, self._dd[v0:v1, u0:u1])
                np.minimum(depth[v0:v1, u0:u1], t, out=depth[v0:v1, u0:u1])
        for box in boxes:
            lo, hi = np.asarray(box.lower_m, float), np.asarray(box.upper_m, float)
            corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
            uv, z = self.camera.project(corners)
            rect = self._rect(uv.tolist(), z.tolist(), 0.0)
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
