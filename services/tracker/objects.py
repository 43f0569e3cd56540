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
Positions in the scene's `base` frame, metres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from services.tracker.lean import histogram_mode, percentiles
from services.tracker.pointcloud import DepthFrame, backproject_pixels, backproject_pixels_xy, base_z

HEIGHT_BIN_M = 0.01
PLANE_INLIER_M = 0.015
#: Pixels kept around the inliers when closing the table mask (5x5 closing: a dilation then an
#: erosion, 2 px each): with 4 the closing of the crop is the closing of the whole image.
CLOSE_MARGIN_PX = 4
#: Pixels kept around the object candidates when opening and labelling them (3x3 opening).
BLOB_MARGIN_PX = 2
_CLOSE_KERNEL = np.ones((5, 5), np.uint8)
_OPEN_KERNEL = np.ones((3, 3), np.uint8)


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
    return _fit_table_plane(frame, base_z(frame), np.isfinite(frame.depth_m), floor_z_m, min_pixels)


def _fit_table_plane(frame: DepthFrame, z: np.ndarray, finite: np.ndarray, floor_z_m: float,
                     min_pixels: int) -> tuple[TablePlane | None, np.ndarray]:
    """`fit_table_plane` with the pixels' heights z (H, W) (m, `base`, `base_z(frame)`) and
    `finite` (H, W) (`isfinite(frame.depth_m)`) given."""
    idx = np.flatnonzero(finite & (z > floor_z_m + 0.3))
    zc = z.ravel()[idx]
    if zc.size < min_pixels:
        return None, np.zeros(z.shape, dtype=bool)
    lo = float(np.min(zc))
    bins = max(1, int(np.ceil((float(np.max(zc)) - lo) / HEIGHT_BIN_M)) + 1)
    k, edges = histogram_mode(zc, bins, lo, lo + bins * HEIGHT_BIN_M)
    z0 = 0.5 * (edges[k] + edges[k + 1])
    x, y = backproject_pixels_xy(frame, idx)  # the candidates' z is zc
    near = np.flatnonzero(np.abs(zc - z0) < PLANE_INLIER_M)
    if len(near) < min_pixels:
        return None, np.zeros(z.shape, dtype=bool)
    design = np.empty((len(near), 3))  # float64 (x, y, 1) rows, as column_stack gave them
    design[:, 0] = x[near]
    design[:, 1] = y[near]
    design[:, 2] = 1.0
    (a, b, c), *_ = np.linalg.lstsq(design, zc[near].astype(float), rcond=None)
    plane = TablePlane(float(a), float(b), float(c), int(len(near)))
    inliers = np.zeros(z.size, dtype=bool)
    inliers[idx[np.abs(zc - (plane.a * x + plane.b * y + plane.c)) < PLANE_INLIER_M]] = True  # height_above
    return plane, inliers.reshape(z.shape)


def _bounds(rows: np.ndarray, cols: np.ndarray, margin: int, shape: tuple[int, ...],
            even: bool = False) -> tuple[int, int, int, int]:
    """(r0, r1, c0, c1): the pixels' bounding box grown by `margin`, inside the image; with
    `even`, r0 and c0 even (OpenCV labels 2x2 blocks: the same grid keeps the label order)."""
    r0, c0 = max(0, int(rows.min()) - margin), max(0, int(cols.min()) - margin)
    if even:
        r0, c0 = r0 & ~1, c0 & ~1
    return r0, min(shape[0], int(rows.max()) + margin + 1), c0, min(shape[1], int(cols.max()) + margin + 1)


def _region_hull(inliers: np.ndarray) -> np.ndarray | None:
    """Convex hull (K, 1, 2) (x, y px) of the largest contour of the closed inlier mask, or
    None; the closing runs on the inliers' box plus `CLOSE_MARGIN_PX` (the same pixels)."""
    inliers = np.asarray(inliers, dtype=bool)
    rows, cols = np.flatnonzero(inliers.any(axis=1)), np.flatnonzero(inliers.any(axis=0))
    if rows.size == 0:
        return None
    r0, r1, c0, c1 = _bounds(rows, cols, CLOSE_MARGIN_PX, inliers.shape)
    crop = np.ascontiguousarray(inliers[r0:r1, c0:c1]).view(np.uint8)  # 0/1: same contours as 0/255
    closed = cv2.morphologyEx(crop, cv2.MORPH_CLOSE, _CLOSE_KERNEL)
    contours, _ = cv2.findContours(closed, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE, offset=(c0, r0))
    if not contours:
        return None
    return cv2.convexHull(max(contours, key=cv2.contourArea))


def table_region(inliers: np.ndarray) -> np.ndarray:
    """Filled table region (H, W) bool: the convex hull of the largest inlier contour."""
    region = np.zeros(inliers.shape, np.uint8)
    hull = _region_hull(inliers)
    if hull is not None:
        cv2.fillPoly(region, [hull], 1)
    return region.view(bool)


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
    z = base_z(frame)
    finite = np.isfinite(frame.depth_m)
    plane, inliers = _fit_table_plane(frame, z, finite, floor_z_m, 500)
    if plane is None:
        return ObjectDetection(False, none, none, None, reason="no table plane in the depth image")
    idx = np.flatnonzero(table_region(inliers) & finite)
    x, y = backproject_pixels_xy(frame, idx)
    height = z.ravel()[idx] - (plane.a * x + plane.b * y + plane.c)  # plane.height_above
    idx = idx[(height > min_height_m) & (height < max_height_m)]
    if exclude_points is not None and idx.size:
        idx = idx[~exclude_points(backproject_pixels(frame, idx).astype(float))]
    blob = _largest_blob(idx, z.shape) if idx.size else idx
    if blob.size == 0:
        return ObjectDetection(False, none, none, plane, reason="nothing stands on the table")
    if blob.size < min_pixels:  # the largest blob's area
        return ObjectDetection(False, none, none, plane,
                               reason=f"largest blob has {int(blob.size)} px < {min_pixels}")
    blob_pts = backproject_pixels(frame, blob)
    pts = blob_pts.astype(float)
    hts = plane.height_above(blob_pts).astype(float)
    lo, hi = percentiles(pts[:, :2], [2, 98])
    top = float(percentiles(hts[:, None], [98])[0, 0])
    centre_xy = 0.5 * (lo + hi)
    table_z = plane.a * centre_xy[0] + plane.b * centre_xy[1] + plane.c
    position = np.array([centre_xy[0], centre_xy[1], table_z + top / 2.0])
    size = np.array([hi[0] - lo[0], hi[1] - lo[1], top])
    return ObjectDetection(True, position, size, plane, pixels=int(blob.size))


def _largest_blob(idx: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Row-major indices of the largest 8-connected blob (the first in OpenCV's label order
    among equals) of the candidate pixels `idx` (sorted, non-empty) after a 3x3 opening;
    empty when the opening leaves nothing.

    The opening and the labelling run on the candidates' box plus `BLOB_MARGIN_PX`, its
    corner on even pixels, which gives the whole image's opening and labels there; the blobs'
    areas are counted over the foreground pixels (OpenCV's statistics scan the whole image).
    """
    rows, cols = np.divmod(idx, shape[1])
    r0, r1, c0, c1 = _bounds(rows, cols, BLOB_MARGIN_PX, shape, even=True)
    cand = np.zeros((r1 - r0, c1 - c0), dtype=np.uint8)
    rows -= r0
    cols -= c0
    cand[rows, cols] = 1
    mask = cv2.morphologyEx(cand, cv2.MORPH_OPEN, _OPEN_KERNEL)
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 1:
        return idx[:0]
    kept = mask[rows, cols] > 0  # an opening keeps a subset of the candidates
    blob_of = labels[rows[kept], cols[kept]]
    areas = np.bincount(blob_of, minlength=n)[1:]
    best = int(np.argmax(areas)) + 1
    return idx[kept][blob_of == best]
