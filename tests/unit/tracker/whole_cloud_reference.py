"""Reference: the tracker's whole-cloud computations as they were before the lean rewrite.

Every depth frame was back-projected whole (rays built per frame), the hand's box searched
over the whole cloud, and the object found on the whole cloud (the table mask closed, the
blobs opened and labelled over the whole image, numpy's histogram and percentiles). The lean code
(`services.tracker.pointcloud`, `objects`, `core`) must give the same results; the
equivalence tests and `tests/bench/test_bench_tracker.py` compare against these.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from handover_model.shapes import Capsule
from services.tracker.core import TrackerPipeline
from services.tracker.corrections import points_in_box, robot_point_mask
from services.tracker.objects import HEIGHT_BIN_M, PLANE_INLIER_M, ObjectDetection, TablePlane
from services.tracker.pointcloud import DepthFrame


def reference_backproject(frame: DepthFrame) -> tuple[np.ndarray, np.ndarray]:
    """Points (H, W, 3) float32 of every pixel in `base`, and validity (H, W)."""
    h, w = frame.depth_m.shape
    z = frame.depth_m.astype(np.float32, copy=False)
    u = (np.arange(w, dtype=np.float32) - np.float32(frame.cx)) / np.float32(frame.fx)
    v = (np.arange(h, dtype=np.float32) - np.float32(frame.cy)) / np.float32(frame.fy)
    r = frame.camera_rotation.astype(np.float32)
    t = frame.camera_position_m.astype(np.float32)
    ray = u[None, :, None] * r[:, 0] + v[:, None, None] * r[:, 1] + r[:, 2]
    points = z[..., None] * ray + t
    return points, np.isfinite(z)


def reference_human_points_near(
    frame: DepthFrame, centre_m: np.ndarray, half_m: float, robot_caps: list[Capsule] | None, margin_m: float
) -> np.ndarray:
    """Whole-cloud points (N, 3) in the cube around `centre_m`, robot points removed."""
    points, valid = reference_backproject(frame)
    flat = points[valid]
    pts = flat[points_in_box(flat, centre_m, half_m)].astype(float)
    if len(pts) and robot_caps is not None:
        pts = pts[~robot_point_mask(pts, robot_caps, margin_m)]
    return pts


def reference_fit_table_plane(
    points_m: np.ndarray, valid: np.ndarray, floor_z_m: float, min_pixels: int = 500
) -> tuple[TablePlane | None, np.ndarray]:
    """Table plane and inlier mask (H, W) from the whole cloud."""
    z = points_m[..., 2]
    cand = valid & (z > floor_z_m + 0.3)
    zc = z[cand]
    if zc.size < min_pixels:
        return None, np.zeros(valid.shape, dtype=bool)
    lo = float(np.min(zc))
    bins = max(1, int(np.ceil((float(np.max(zc)) - lo) / HEIGHT_BIN_M)) + 1)
    counts, edges = np.histogram(zc, bins=bins, range=(lo, lo + bins * HEIGHT_BIN_M))
    k = int(np.argmax(counts))
    z0 = 0.5 * (edges[k] + edges[k + 1])
    near = cand & (np.abs(z - z0) < PLANE_INLIER_M)
    pts = points_m[near]
    if len(pts) < min_pixels:
        return None, np.zeros(valid.shape, dtype=bool)
    design = np.column_stack([pts[:, 0], pts[:, 1], np.ones(len(pts))])
    (a, b, c), *_ = np.linalg.lstsq(design.astype(float), pts[:, 2].astype(float), rcond=None)
    plane = TablePlane(float(a), float(b), float(c), int(len(pts)))
    inliers = cand & (np.abs(plane.height_above(points_m)) < PLANE_INLIER_M)
    return plane, inliers


def reference_table_region(inliers: np.ndarray) -> np.ndarray:
    """Filled table region (H, W) bool: the convex hull of the largest contour of the inlier
    mask closed over the whole image."""
    mask: np.ndarray = inliers.astype(np.uint8) * 255
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    region = np.zeros_like(mask)
    if contours:
        biggest = max(contours, key=cv2.contourArea)
        cv2.fillPoly(region, [cv2.convexHull(biggest)], 255)
    return region > 0


def reference_detect_object(
    frame: DepthFrame,
    floor_z_m: float,
    exclude_points: Callable[[np.ndarray], np.ndarray] | None = None,
    min_height_m: float = 0.02,
    max_height_m: float = 0.40,
    min_pixels: int = 20,
) -> ObjectDetection:
    """The object on the table, computed on the whole back-projected cloud."""
    points_m, valid = reference_backproject(frame)
    none = np.zeros(3)
    plane, inliers = reference_fit_table_plane(points_m, valid, floor_z_m)
    if plane is None:
        return ObjectDetection(False, none, none, None, reason="no table plane in the depth image")
    region = reference_table_region(inliers)
    height = np.where(valid, plane.height_above(points_m), np.nan)
    with np.errstate(invalid="ignore"):
        cand = region & valid & (height > min_height_m) & (height < max_height_m)
    if exclude_points is not None:
        idx = np.flatnonzero(cand)
        if idx.size:
            drop = exclude_points(points_m.reshape(-1, 3)[idx].astype(float))
            cand.ravel()[idx[drop]] = False
    mask = cv2.morphologyEx(cand.astype(np.uint8), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1:
        return ObjectDetection(False, none, none, plane, reason="nothing stands on the table")
    areas = stats[1:, cv2.CC_STAT_AREA]
    best = int(np.argmax(areas)) + 1
    if stats[best, cv2.CC_STAT_AREA] < min_pixels:
        return ObjectDetection(False, none, none, plane,
                               reason=f"largest blob has {int(areas.max())} px < {min_pixels}")
    blob = labels == best
    pts = points_m[blob].astype(float)
    hts = height[blob].astype(float)
    lo = np.percentile(pts[:, :2], 2, axis=0)
    hi = np.percentile(pts[:, :2], 98, axis=0)
    top = float(np.percentile(hts, 98))
    centre_xy = 0.5 * (lo + hi)
    table_z = plane.a * centre_xy[0] + plane.b * centre_xy[1] + plane.c
    position = np.array([centre_xy[0], centre_xy[1], table_z + top / 2.0])
    size = np.array([hi[0] - lo[0], hi[1] - lo[1], top])
    return ObjectDetection(True, position, size, plane, pixels=int(blob.sum()))


class ReferencePipeline(TrackerPipeline):
    """The tracker pipeline with the whole-cloud hand search and object detection."""

    def _human_points_near(self, centre_m: np.ndarray, half_m: float, now_s: float) -> np.ndarray:
        caps, _ = self._robot(now_s)
        caps = caps if self.config.remove_robot_points else None
        return reference_human_points_near(self._depth, centre_m, half_m, caps, self.config.robot_point_margin_m)

    def detect_object(self, force: bool = False) -> ObjectDetection | None:
        if self._depth is None or not (self._object_due or force):
            return None
        self._object_due = False
        cfg = self.config
        return reference_detect_object(
            self._depth, cfg.floor_z_m, self._excluded_points, cfg.object_min_height_m, cfg.object_max_height_m,
            cfg.object_min_pixels,
        )
