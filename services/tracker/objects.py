"""The object on the table (thesis OBJ block), from one depth image with OpenCV.

1. Table plane: among points more than 0.3 m above the floor, the most populated 1 cm
   height bin is the table top; a least-squares plane z = a x + b y + c through the points
   within 1.5 cm of it refines it (a slightly tilted table or camera is fine).
2. Table region: the plane's inlier pixels, closed (`cv2.morphologyEx`), their largest
   outer contour (`cv2.findContours`) filled as its convex hull (`cv2.convexHull`), so the
   holes the object cuts into the table top belong to the table.
3. Object pixels: inside the table region, between `min_height_m` and `max_height_m` above
   the plane, not excluded (robot, person); opened to drop speckle; blobs from
   `cv2.connectedComponents`; the largest blob of at least `min_pixels` wins.
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

from services.tracker.pointcloud import DepthFrame, backproject_pixels, base_z

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


def fit_table_plane(frame: DepthFrame, floor_z_m: float, min_pixels: int = 500) -> tuple[TablePlane | None, np.ndarray]:
    """Find the table top in a depth frame.

    Only the pixels more than 0.3 m above the floor are back-projected (the heights of all
    pixels come from `base_z`, a third of a back-projection).

    Returns:
        (plane or None, inlier mask (H, W) bool).
    """
    shape = frame.depth_m.shape
    z = base_z(frame)
    cand = np.isfinite(frame.depth_m) & (z > floor_z_m + 0.3)
    idx = np.flatnonzero(cand)
    zc = z.ravel()[idx]
    if zc.size < min_pixels:
        return None, np.zeros(shape, dtype=bool)
    lo = float(np.min(zc))
    bins = max(1, int(np.ceil((float(np.max(zc)) - lo) / HEIGHT_BIN_M)) + 1)
    counts, edges = np.histogram(zc, bins=bins, range=(lo, lo + bins * HEIGHT_BIN_M))
    k = int(np.argmax(counts))
    z0 = 0.5 * (edges[k] + edges[k + 1])
    cand_pts = backproject_pixels(frame, idx)
    near = np.flatnonzero(np.abs(zc - z0) < PLANE_INLIER_M)
    x, y, zn = np.take(cand_pts.T, near, axis=1)  # component rows: fast to gather
    if len(zn) < min_pixels:
        return None, np.zeros(shape, dtype=bool)
    design = np.column_stack([x, y, np.ones(len(zn))])
    (a, b, c), *_ = np.linalg.lstsq(design.astype(float), zn.astype(float), rcond=None)
    plane = TablePlane(float(a), float(b), float(c), int(len(zn)))
    inliers = np.zeros(cand.size, dtype=bool)
    inliers[idx[np.abs(plane.height_above(cand_pts)) < PLANE_INLIER_M]] = True
    return plane, inliers.reshape(shape)


def table_region(inliers: np.ndarray) -> np.ndarray:
    """Filled table region (H, W) bool: the convex hull of the largest inlier contour."""
    mask: np.ndarray = inliers.astype(np.uint8) * 255
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    region = np.zeros_like(mask)
    if contours:
        biggest = max(contours, key=cv2.contourArea)
        cv2.fillPoly(region, [cv2.convexHull(biggest)], 255)
    return region > 0


def detect_object(
    frame: DepthFrame,
    floor_z_m: float,
    exclude_points: Callable[[np.ndarray], np.ndarray] | None = None,
    min_height_m: float = 0.02,
    max_height_m: float = 0.40,
    min_pixels: int = 20,
) -> ObjectDetection:
    """Find the largest object standing on the table.

    Back-projects only the pixels each step needs (those above the floor for the plane, the
    table region's for the object, the blob's for its extents), with the points
    `backproject` gives there, so the result is that of the whole cloud.

    Args:
        frame: the depth frame (camera pose in `base`).
        floor_z_m: floor height in `base`.
        exclude_points: a function from candidate points (N, 3) to a mask (N,) of the points
            that belong to the robot or the person (run on candidates only: cheap).
        min_height_m, max_height_m: object points lie this high above the table.
        min_pixels: smallest blob taken as an object.
    """
    none = np.zeros(3)
    plane, inliers = fit_table_plane(frame, floor_z_m)
    if plane is None:
        return ObjectDetection(False, none, none, None, reason="no table plane in the depth image")
    region = table_region(inliers)
    idx = np.flatnonzero(region & np.isfinite(frame.depth_m))
    height = plane.height_above(backproject_pixels(frame, idx))
    idx = idx[(height > min_height_m) & (height < max_height_m)]
    if exclude_points is not None and idx.size:
        idx = idx[~exclude_points(backproject_pixels(frame, idx).astype(float))]
    cand = np.zeros(region.size, dtype=np.uint8)
    cand[idx] = 1
    mask = cv2.morphologyEx(cand.reshape(region.shape), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    # The blobs' areas counted over the few foreground pixels (OpenCV's statistics scan the
    # whole image and cost several times the labelling).
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 1:
        return ObjectDetection(False, none, none, plane, reason="nothing stands on the table")
    foreground = idx[mask.ravel()[idx] > 0]  # an opening keeps a subset of the candidates
    blob_of = labels.ravel()[foreground]
    areas = np.bincount(blob_of, minlength=n)[1:]
    best = int(np.argmax(areas)) + 1
    if areas[best - 1] < min_pixels:
        return ObjectDetection(False, none, none, plane,
                               reason=f"largest blob has {int(areas.max())} px < {min_pixels}")
    blob = foreground[blob_of == best]
    blob_pts = backproject_pixels(frame, blob)
    pts = blob_pts.astype(float)
    hts = plane.height_above(blob_pts).astype(float)
    lo, hi = np.percentile(pts[:, :2], [2, 98], axis=0)
    top = float(np.percentile(hts, 98))
    centre_xy = 0.5 * (lo + hi)
    table_z = plane.a * centre_xy[0] + plane.b * centre_xy[1] + plane.c
    position = np.array([centre_xy[0], centre_xy[1], table_z + top / 2.0])
    size = np.array([hi[0] - lo[0], hi[1] - lo[1], top])
    return ObjectDetection(True, position, size, plane, pixels=int(blob.size))
