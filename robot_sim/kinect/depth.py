"""Depth rendering of the scene as a Kinect v1 sees it (numpy ray casting).

Each primitive is intersected only with the rays inside its projected bounding rectangle
(exact bounds of its end spheres, so no hit lies outside). Depths are z along the optical
axis (metres). `DepthRenderer.render` casts what it is given every call: the reference.
Frame after frame, `robot_sim.kinect.scene_depth.SceneDepthRenderer` casts only what moved,
and `robot_sim.kinect.quantise.DepthQuantiser` gives `kinect_depth_mm`'s readings from kept
buffers; both give the same values as the plain functions here.

Noise model (Khoshelham & Elberink 2012, "Accuracy and resolution of Kinect depth data"): the
Kinect v1 measures disparity d = f·b / z, counted in 1/8-pixel steps (f = 571 px at full
resolution, b = 0.075 m), and its random error is a constant error in disparity, whose effect
on depth grows with z². We draw it in disparity steps, σ_d = c·f·b / step ≈ 0.488 steps with
c = `DEPTH_NOISE_COEFF_PER_M`, the disparity error whose first-order depth error is the paper's
σ_z = c·z² (m): the reading is k = round(d + σ_d·N) steps (N standard normal), z = f·b / (k·step),
rounded to millimetres; the integer k gives Kinect v1's depth steps (≈ 1 cm at 2 m). N comes
from a table of Gaussian quantiles indexed by a uniform 16-bit draw (`DISPARITY_NOISE_TABLE_STEPS`).
A pixel reads 0 (no reading) when its ideal depth or its reading is outside the 0.5–4.5 m
range, and each pixel drops out independently with probability `dropout_fraction`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.special import ndtri

from robot_sim.kinect import camera as cam
from robot_sim.kinect.camera import KinectCamera
from handover_model.shapes import Box, Capsule, ray_box, ray_capsule, ray_horizontal_plane

#: Random depth error coefficient (m⁻¹): σ_z = coefficient · z² (to first order).
DEPTH_NOISE_COEFF_PER_M = 1.425e-3
#: f·b / step (disparity steps · m): the disparity of depth z (m) is this / z, in steps.
DISPARITY_DEPTH_STEPS_M = cam.KINECT_FULL_RES_FOCAL_PX * cam.KINECT_BASELINE_M / cam.KINECT_DISPARITY_STEP_PX
#: σ of the random disparity error, in disparity steps (≈ 0.488): σ_z = c·z² in depth.
DISPARITY_NOISE_STEPS = DEPTH_NOISE_COEFF_PER_M * DISPARITY_DEPTH_STEPS_M
#: Number of entries of the Gaussian table (a uniform uint16 draw indexes it).
NOISE_TABLE_SIZE = 65536
#: Disparity errors (steps, float32): σ_d · Φ⁻¹((i + 0.5) / 65536), the exact quantiles of a
#: Gaussian discretised into 65536 equally likely values. Indexed by a uniform uint16 draw, it
#: gives σ_d·N with the tails truncated at about 4.3 σ_d (|N| ≤ 4.32; a normal goes beyond with
#: probability 1.5e-5): one 2-byte draw per pixel instead of a float64 normal.
DISPARITY_NOISE_TABLE_STEPS = (DISPARITY_NOISE_STEPS * ndtri((np.arange(NOISE_TABLE_SIZE) + 0.5)
                                                             / NOISE_TABLE_SIZE)).astype(np.float32)
DISPARITY_NOISE_TABLE_STEPS.flags.writeable = False
#: A primitive that comes within this distance (m) of the camera's plane is cast over the
#: whole image (its projection is unbounded or nearly so).
NEAR_PLANE_M = 0.05

#: A pixel rectangle (u0, u1, v0, v1): columns u0..u1-1, rows v0..v1-1.
Rect = tuple[int, int, int, int]


class DepthRenderer:
    """Ray-casts capsules, boxes and the floor into a depth image.

    Args:
        camera: the camera (pose and intrinsics).
    """

    def __init__(self, camera: KinectCamera) -> None:
        self.camera = camera
        self.rays = camera.rays_base()
        self.dd = np.einsum("...i,...i->...", self.rays, self.rays)
        self._h, self._w = camera.height_px, camera.width_px

    def _bounds(self, centres_m: np.ndarray, radii_m: np.ndarray) -> tuple[np.ndarray, ...]:
        """Exact image bounds of spheres (centres (N, 3) m in `base`, radii (N,) m).

        A plane through the optical centre that touches a sphere at (x, z) (optical frame,
        z > r) has slope k = (x z ± r sqrt(x² + z² − r²)) / (z² − r²); the pixel column of
        that plane is fx k + cx (rows alike with y, fy, cy).

        Returns:
            (u_lo, u_hi, v_lo, v_hi) in pixels, `near` (the sphere reaches within
            `NEAR_PLANE_M` of the camera's plane: bounds unusable) and `behind` (the whole
            sphere is behind the camera), each (N,).
        """
        p = (np.asarray(centres_m, float) - self.camera.position_m) @ self.camera.rotation
        x, y, z = p[:, 0], p[:, 1], p[:, 2]
        r = np.asarray(radii_m, float)
        behind = z + r <= 0.0
        near = z - r <= NEAR_PLANE_M
        den = np.where(near, 1.0, z * z - r * r)
        bounds = []
        for w, f, c in ((x, self.camera.fx_px, self.camera.cx_px), (y, self.camera.fy_px, self.camera.cy_px)):
            spread = r * np.sqrt(np.maximum(w * w + den, 0.0))
            bounds += [f * (w * z - spread) / den + c, f * (w * z + spread) / den + c]
        return (*bounds, near, behind)

    def _rects(self, centres_m: np.ndarray, radii_m: np.ndarray, groups: int) -> list[Rect | None]:
        """Pixel rectangles (u0, u1, v0, v1), end-exclusive, that hold the projections of
        `groups` convex hulls of the same number of spheres each (rows of `centres_m` in
        group order); None where nothing can be visible. The projection of a convex set in
        front of the camera is the convex hull of its parts' projections, so the union of
        the spheres' bounds holds it; one pixel of margin on each side absorbs rounding."""
        if groups == 0:
            return []
        u_lo, u_hi, v_lo, v_hi, near, behind = (a.reshape(groups, -1) for a in self._bounds(centres_m, radii_m))
        rects: list[Rect | None] = []
        for g in range(groups):
            if behind[g].all():
                rects.append(None)
            elif near[g].any():
                rects.append((0, self._w, 0, self._h))
            else:
                u0 = max(math.floor(u_lo[g].min()) - 1, 0)
                u1 = min(math.ceil(u_hi[g].max()) + 2, self._w)
                v0 = max(math.floor(v_lo[g].min()) - 1, 0)
                v1 = min(math.ceil(v_hi[g].max()) + 2, self._h)
                rects.append((u0, u1, v0, v1) if u0 < u1 and v0 < v1 else None)
        return rects

    def capsule_rects(self, capsules: Sequence[Capsule]) -> list[Rect | None]:
        """Conservative pixel rectangle of each capsule (None: not in view)."""
        if not capsules:
            return []
        ends = np.array([(c.a_m, c.b_m) for c in capsules], float).reshape(-1, 3)
        radii = np.repeat([c.radius_m for c in capsules], 2)
        return self._rects(ends, radii, len(capsules))

    def box_rects(self, boxes: Sequence[Box]) -> list[Rect | None]:
        """Conservative pixel rectangle of each box, from its 8 corners (None: not in view)."""
        if not boxes:
            return []
        corners = np.array([[(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
                            for lo, hi in ((np.asarray(b.lower_m, float), np.asarray(b.upper_m, float))
                                           for b in boxes)]).reshape(-1, 3)
        return self._rects(corners, np.zeros(len(corners)), len(boxes))

    def render(
        self,
        capsules: list[Capsule],
        boxes: Sequence[Box] = (),
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
        for capsule, rect in zip(capsules, self.capsule_rects(capsules), strict=True):
            if rect is None:
                continue
            u0, u1, v0, v1 = rect
            t = ray_capsule(origin, self.rays[v0:v1, u0:u1], capsule, self.dd[v0:v1, u0:u1])
            np.minimum(depth[v0:v1, u0:u1], t, out=depth[v0:v1, u0:u1])
        for box, rect in zip(boxes, self.box_rects(boxes), strict=True):
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

    The plain reference of `robot_sim.kinect.quantise.DepthQuantiser` (same values, same
    random draws in the same order): a uniform uint16 per pixel for the noise, then, with
    dropouts, the number of dropped pixels (binomial) and which ones.

    Args:
        depth_m: ideal depths.
        rng: random generator for noise and dropouts; None gives the quantised, noise-free
            image (for tests).
        dropout_fraction: probability that a pixel has no reading.
    """
    z = np.array(depth_m, dtype=float)
    valid = np.isfinite(z) & (z >= cam.KINECT_MIN_RANGE_M) & (z <= cam.KINECT_MAX_RANGE_M)
    d = DISPARITY_DEPTH_STEPS_M / np.where(valid, z, 1.0)  # ideal disparity, steps
    if rng is None:
        k = np.rint(d)
    else:
        # k = round(d + σ_d·N) = floor(d + 0.5 + σ_d·N), summed in float32 like the quantiser.
        noise = DISPARITY_NOISE_TABLE_STEPS[rng.integers(0, NOISE_TABLE_SIZE, size=z.shape, dtype=np.uint16)]
        k = np.floor((d + 0.5).astype(np.float32) + noise).astype(float)
    zq = DISPARITY_DEPTH_STEPS_M / np.maximum(k, 1.0)  # the reading, m
    valid &= (zq >= cam.KINECT_MIN_RANGE_M) & (zq <= cam.KINECT_MAX_RANGE_M)
    mm = np.where(valid, np.round(zq * 1000.0), 0).astype(np.uint16)
    if rng is not None and dropout_fraction > 0.0:
        # Bernoulli(p) per pixel: the number of dropouts, then which pixels.
        mm.flat[rng.choice(z.size, rng.binomial(z.size, dropout_fraction), replace=False)] = 0
    return mm
