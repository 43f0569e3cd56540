"""Depth images to 3-D points in Baxter's `base` frame.

A pixel (u, v) with depth z (along the optical axis) is the optical-frame point
(z (u − cx)/fx, z (v − cy)/fy, z), then `p_base = R p_optical + t` with the camera's pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from bus_schema.messages import DepthImage


@dataclass(frozen=True)
class DepthFrame:
    """A depth image with its camera.

    Attributes:
        depth_m: (H, W) depth along the optical axis (m), NaN where there is no reading.
        fx, fy, cx, cy: intrinsics (px).
        camera_position_m: optical centre in `base` (3,).
        camera_rotation: (3, 3) optical frame → `base`.
        t_s: local receive time (s, monotonic clock).
    """

    depth_m: np.ndarray
    fx: float
    fy: float
    cx: float
    cy: float
    camera_position_m: np.ndarray
    camera_rotation: np.ndarray
    t_s: float = 0.0


def depth_frame_from_message(msg: DepthImage, t_s: float) -> DepthFrame:
    """Decode a `DepthImage` (uint16 mm, 0 = none) into a `DepthFrame` received at `t_s`."""
    mm = np.frombuffer(msg.depth_mm, dtype="<u2").reshape(msg.height, msg.width)
    depth = mm.astype(np.float32) * np.float32(0.001)
    depth[mm == 0] = np.nan
    quat = np.asarray(msg.camera_orientation_xyzw, float)
    norm = np.linalg.norm(quat)
    rot = Rotation.from_quat(quat / norm).as_matrix() if norm > 1e-6 else np.eye(3)
    return DepthFrame(
        depth_m=depth,
        fx=msg.fx,
        fy=msg.fy,
        cx=msg.cx,
        cy=msg.cy,
        camera_position_m=np.asarray(msg.camera_position_m, float),
        camera_rotation=rot,
        t_s=t_s,
    )


def backproject(frame: DepthFrame) -> tuple[np.ndarray, np.ndarray]:
    """Points of every pixel in `base`.

    Returns:
        (points (H, W, 3) float32 metres, NaN where no reading; valid (H, W) bool).
    """
    h, w = frame.depth_m.shape
    z = frame.depth_m.astype(np.float32, copy=False)
    u = (np.arange(w, dtype=np.float32) - np.float32(frame.cx)) / np.float32(frame.fx)
    v = (np.arange(h, dtype=np.float32) - np.float32(frame.cy)) / np.float32(frame.fy)
    r = frame.camera_rotation.astype(np.float32)
    t = frame.camera_position_m.astype(np.float32)
    # p_base = z * (u R[:,0] + v R[:,1] + R[:,2]) + t, built without an (H, W, 3) matmul.
    ray = u[None, :, None] * r[:, 0] + v[:, None, None] * r[:, 1] + r[:, 2]
    points = z[..., None] * ray + t
    return points, np.isfinite(z)
