"""The object on the table (thesis OBJ block), from one depth image with OpenCV.

1. Table plane: among points more than 0.3 m above the floor, the most populated 1 cm
   height bin is the table top; a least-squares plane z = a x + b y + c through the points
   within 1.5 cm of it refines it (a slightly tilted table or camera is fine).
2. Table region: the plane's inlier pixels, closed (`cv2.morphologyEx`), their largest
   outer contour (`cv2.findContours`) filled as its convex hull (`cv2.convexHull`), so the
   holes the object cuts into the table top belong to the table.
3. Object pixels: inside the table region, between `min_height_m` and `max_height_m` above
   the plane, not excluded (robot, person); opened to drop speckle; blobs from
   `cv2.connectedComponentsWithStats`; the largest blob of at least `min_pixels` wins.
4. Position and size: x, y extents from the 2nd–98th percentiles of the blob's points (the
   camera sees the top face), height from the 98th percentile above the plane; the centre is
   halfway up.
Positions in Baxter's `base` frame, metres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

HEIGHT_BIN_M = 0.01
PLANE_INLIER_M = 0.015


@dataclass(frozen=True)
class TablePlane:
    """z = a x + b y + c in `base` (metres); `pixels` is the number of inlier pixels."""

    a: float
    b: float
    c: float
    pixels: int

    def height_above(self, points_m: np.ndarray) -> np.ndarray:
        """Height (m) of points (..., 3) above the plane, measured along z."""
        return points_m[..., 2] - (self.a * points_m[..., 0] + self.b * points_m[..., 1] + self.c)


@dataclass(frozen=True)
class ObjectDetection:
    """Result of one detection.

    Attributes:
        found: an object blob was found.
        position_m: object centre (3,), `base`.
        size_m: extents (x, y, z) in metres.
        table: the table plane (None when no table was found).
        pixels: pixels in the object's blob.
        reason: why nothing was found ("" when found).
    """

    found: bool
    position_m: np.ndarray
    size_m: np.ndarray
    table: TablePlane | None
    pixels: int = 0
    reason: str = ""


def fit_table_plane(points_m: np.ndarray, valid: np.ndarray, floor_z_m: float, min_pixels: int = 500) -> tuple[TablePlane | None, np.ndarray]:
    """Find the table top.

    Returns:
        (plane or None, inlier mask (H, W) bool).
    """
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


def table_region(inliers: np.ndarray) -> np.ndarray:
    """Filled table region (H, W) bool: the convex hull of the largest inlier contour."""
    mask = inliers.astype(np.uint8) * 255
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    region = np.zeros_like(mask)
    if contours:
        biggest = max(contours, key=cv2.contourArea)
        cv2.fillPoly(region, [cv2.convexHull(biggest)], 255)
    return region > 0


def detect_object(
    points_m: np.ndarray,
    valid: np.ndarray,
    floor_z_m: float,
    exclude: np.ndarray | None = None,
    exclude_points: Callable[[np.ndarray], np.ndarray] | None = None,
    min_height_m: float = 0.02,
    max_height_m: float = 0.40,
    min_pixels: int = 20,
) -> ObjectDetection:
    """Find the largest object standing on the table.

    Args:
        points_m: (H, W, 3) back-projected points (`base`), NaN where no reading.
        valid: (H, W) pixels with a reading.
        floor_z_m: floor height in `base`.
        exclude: (H, W) pixels that belong to the robot or the person.
        exclude_points: or a function from candidate points (N, 3) to a mask (N,) of the
            points that belong to the robot or the person (run on candidates only: cheap).
        min_height_m, max_height_m: object points lie this high above the table.
        min_pixels: smallest blob taken as an object.
    """
    none = np.zeros(3)
    plane, inliers = fit_table_plane(points_m, valid, floor_z_m)
    if plane is None:
        return ObjectDetection(False, none, none, None, reason="no table plane in the depth image")
    region = table_region(inliers)
    height = np.where(valid, plane.height_above(points_m), np.nan)
    with np.errstate(invalid="ignore"):
        cand = region & valid & (height > min_height_m) & (height < max_height_m)
    if exclude is not None:
        cand &= ~exclude
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
        return ObjectDetection(False, none, none, plane, reason=f"largest blob has {int(areas.max())} px < {min_pixels}")
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
