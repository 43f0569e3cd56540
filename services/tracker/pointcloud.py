"""Depth images to 3-D points in the scene's `base` frame.

A pixel (u, v) with depth z (along the optical axis) is the optical-frame point
(z (u − cx)/fx, z (v − cy)/fy, z), then `p_base = R p_optical + t` with the camera's pose,
computed as `p_base = z ray(u, v) + t` with the per-pixel ray `R ((u − cx)/fx, (v − cy)/fy, 1)`.

The rays depend on the camera only, so they are built once per camera (`camera_rays`), and
the points of any set of pixels (`backproject_window`, `backproject_pixels`) are bitwise the
points the whole image (`backproject`) gives at those pixels: callers back-project only the
pixels they need.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import lru_cache
from itertools import product

import numpy as np
from scipy.spatial.transform import Rotation

from bus_schema.messages import DepthImage

#: Pixels added on every side of a projected box: covers the float32 rounding of the points.
WINDOW_MARGIN_PX = 2
#: Unit cube corners (8, 3), for projecting a box.
_CORNERS = np.array(list(product((-1.0, 1.0), repeat=3)))


class DepthFrame:
    """A depth image with its camera.

    Attributes:
        depth_m: (H, W) depth along the optical axis (m), NaN where there is no reading.
            May be given as a function that makes it: it is then called at the first read
            (a simulated camera's frame that nothing reads costs no readings,
            `robot_sim.kinect.readings`).
        fx, fy, cx, cy: intrinsics (px).
        camera_position_m: optical centre in `base` (3,).
        camera_rotation: (3, 3) optical frame → `base`.
        t_s: local receive time (s, monotonic clock).
    """

    def __init__(self, depth_m: np.ndarray | Callable[[], np.ndarray], fx: float, fy: float, cx: float,
                 cy: float, camera_position_m: np.ndarray, camera_rotation: np.ndarray, t_s: float = 0.0) -> None:
        self._depth_m = depth_m
        self.fx, self.fy, self.cx, self.cy = fx, fy, cx, cy
        self.camera_position_m = camera_position_m
        self.camera_rotation = camera_rotation
        self.t_s = t_s

    @property
    def depth_m(self) -> np.ndarray:
        depth = self._depth_m
        if callable(depth):
            depth = self._depth_m = depth()
        return depth


def depth_frame_from_message(msg: DepthImage, t_s: float) -> DepthFrame:
    """Decode a `DepthImage` (uint16 mm, 0 = none) into a `DepthFrame` received at `t_s`."""
    mm = np.frombuffer(msg.depth_mm, dtype="<u2").reshape(msg.height, msg.width)
    depth = mm.astype(np.float32) * np.float32(0.001)
    depth[mm == 0] = np.nan
    return depth_frame_from_camera(depth, msg.fx, msg.fy, msg.cx, msg.cy, msg.camera_position_m,
                                   msg.camera_orientation_xyzw, t_s)


def depth_frame_from_camera(depth_m: np.ndarray | Callable[[], np.ndarray], fx: float, fy: float, cx: float,
                            cy: float, camera_position_m: Sequence[float],
                            camera_orientation_xyzw: Sequence[float], t_s: float) -> DepthFrame:
    """A `DepthFrame` from depth (m, NaN = none; or a function that makes it) and the
    `DepthImage` fields of its camera (px; m and quaternion x, y, z, w in `base`)."""
    return DepthFrame(
        depth_m=depth_m,
        fx=fx,
        fy=fy,
        cx=cx,
        cy=cy,
        camera_position_m=np.asarray(camera_position_m, float),
        camera_rotation=_rotation(tuple(camera_orientation_xyzw)),
        t_s=t_s,
    )


@lru_cache(maxsize=8)
def _rotation(quat_xyzw: tuple[float, ...]) -> np.ndarray:
    """Rotation matrix (3, 3) of a quaternion (identity when it has no length); read-only."""
    quat = np.asarray(quat_xyzw, float)
    norm = np.linalg.norm(quat)
    rot = Rotation.from_quat(quat / norm).as_matrix() if norm > 1e-6 else np.eye(3)
    rot.setflags(write=False)
    return rot


@lru_cache(maxsize=8)
def _rays(h: int, w: int, fx: float, fy: float, cx: float, cy: float, rotation: bytes) -> np.ndarray:
    r = np.frombuffer(rotation, dtype=np.float32).reshape(3, 3)
    u = (np.arange(w, dtype=np.float32) - np.float32(cx)) / np.float32(fx)
    v = (np.arange(h, dtype=np.float32) - np.float32(cy)) / np.float32(fy)
    # z * (u R[:,0] + v R[:,1] + R[:,2]) + t is the point, built without an (H, W, 3) matmul.
    ray = u[None, :, None] * r[:, 0] + v[:, None, None] * r[:, 1] + r[:, 2]
    # Component-major: gathers and products then run on contiguous rows, not on triples.
    rays = np.ascontiguousarray(np.moveaxis(ray, -1, 0))
    rays.setflags(write=False)
    return rays


def camera_rays(frame: DepthFrame) -> np.ndarray:
    """Per-pixel rays (3, H, W) float32 in `base`, component-major: the point of pixel (v, u)
    is `depth[v, u] * rays[:, v, u] + position`. Cached per camera (intrinsics, image size,
    rotation); read-only."""
    h, w = frame.depth_m.shape
    rot = np.ascontiguousarray(frame.camera_rotation, dtype=np.float32)
    return _rays(h, w, float(frame.fx), float(frame.fy), float(frame.cx), float(frame.cy), rot.tobytes())


def backproject(frame: DepthFrame) -> tuple[np.ndarray, np.ndarray]:
    """Points of every pixel in `base`.

    Returns:
        (points (H, W, 3) float32 metres, NaN where no reading; valid (H, W) bool).
    """
    return backproject_window(frame, slice(None), slice(None))


def backproject_window(frame: DepthFrame, rows: slice, cols: slice) -> tuple[np.ndarray, np.ndarray]:
    """Points of the pixels `[rows, cols]` in `base`, equal to `backproject(frame)[rows, cols]`.

    Returns:
        (points (h, w, 3) float32 metres (a view of a (3, h, w) array), NaN where no reading;
        valid (h, w) bool).
    """
    return np.moveaxis(_window_xyz(frame, rows, cols), 0, -1), np.isfinite(frame.depth_m[rows, cols])


def _window_xyz(frame: DepthFrame, rows: slice, cols: slice) -> np.ndarray:
    """Points (3, h, w) float32 of the pixels `[rows, cols]`, component-major."""
    z = frame.depth_m[rows, cols].astype(np.float32, copy=False)
    points = camera_rays(frame)[:, rows, cols] * z
    points += frame.camera_position_m.astype(np.float32)[:, None, None]
    return points


def backproject_pixels(frame: DepthFrame, flat_index: np.ndarray) -> np.ndarray:
    """Points (N, 3) float32 in `base` of the pixels with row-major indices `flat_index` (N,),
    equal to `backproject(frame)[0].reshape(-1, 3)[flat_index]` (a view of a (3, N) array)."""
    z = frame.depth_m.astype(np.float32, copy=False).ravel()[flat_index]
    rays = camera_rays(frame)
    points = np.take(rays.reshape(3, -1), flat_index, axis=1)
    points *= z
    points += frame.camera_position_m.astype(np.float32)[:, None]
    return points.T


def backproject_pixels_xy(frame: DepthFrame, flat_index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x and y (N,) float32 in `base` (m) of the pixels with row-major indices `flat_index`
    (N,): the first two columns of `backproject_pixels(frame, flat_index)` (the same float32
    products and sums), for callers that have the heights already (`base_z`)."""
    z = frame.depth_m.astype(np.float32, copy=False).ravel()[flat_index]
    rays = camera_rays(frame).reshape(3, -1)
    position = frame.camera_position_m.astype(np.float32)
    x = np.take(rays[0], flat_index)
    x *= z
    x += position[0]
    y = np.take(rays[1], flat_index)
    y *= z
    y += position[1]
    return x, y


def base_z(frame: DepthFrame) -> np.ndarray:
    """Height (H, W) float32 in `base` (m) of every pixel's point, NaN where no reading; equal
    to `backproject(frame)[0][..., 2]` at a third of its cost."""
    z = np.multiply(frame.depth_m.astype(np.float32, copy=False), camera_rays(frame)[2])
    z += frame.camera_position_m.astype(np.float32)[2]
    return z


def box_pixel_window(frame: DepthFrame, centre_m: np.ndarray, half_size_m: float) -> tuple[slice, slice]:
    """Image window (rows, cols) holding every pixel whose point can lie in the axis-aligned
    cube of half edge `half_size_m` (m) centred on `centre_m` (3,), `base`.

    The cube's image lies in the bounding box of its 8 projected corners (a convex body in
    front of the camera projects into the hull of its projected vertices); the window adds
    `WINDOW_MARGIN_PX`. When a corner is not in front of the camera, the whole image; when
    the cube is not finite, no pixel (no point is inside it).
    """
    h, w = frame.depth_m.shape
    corners = np.asarray(centre_m, float) + half_size_m * _CORNERS
    if not np.all(np.isfinite(corners)):
        return slice(0, 0), slice(0, 0)
    optical = (corners - frame.camera_position_m) @ np.asarray(frame.camera_rotation, float)
    depth = optical[:, 2]
    if np.any(depth <= 1e-6):
        return slice(0, h), slice(0, w)
    u = frame.fx * optical[:, 0] / depth + frame.cx
    v = frame.fy * optical[:, 1] / depth + frame.cy
    m = WINDOW_MARGIN_PX
    c0, c1 = int(np.clip(np.floor(u.min()) - m, 0, w)), int(np.clip(np.ceil(u.max()) + m + 1, 0, w))
    r0, r1 = int(np.clip(np.floor(v.min()) - m, 0, h)), int(np.clip(np.ceil(v.max()) + m + 1, 0, h))
    return slice(r0, max(r0, r1)), slice(c0, max(c0, c1))


def box_points(frame: DepthFrame, centre_m: np.ndarray, half_size_m: float) -> np.ndarray:
    """Points (N, 3) float32 in `base` inside the axis-aligned cube of half edge `half_size_m`
    (m) centred on `centre_m` (3,), in row-major pixel order: the points of the whole cloud
    that `services.tracker.corrections.points_in_box` keeps (same float32 test), found in the
    cube's image window only (`box_pixel_window`). Pixels without a reading are never inside."""
    rows, cols = box_pixel_window(frame, centre_m, half_size_m)
    xyz = _window_xyz(frame, rows, cols)
    centre = np.asarray(centre_m, dtype=np.float32)
    inside = np.abs(xyz[0] - centre[0]) <= half_size_m
    inside &= np.abs(xyz[1] - centre[1]) <= half_size_m
    inside &= np.abs(xyz[2] - centre[2]) <= half_size_m
    return np.take(xyz.reshape(3, -1), np.flatnonzero(inside), axis=1).T
