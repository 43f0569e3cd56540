"""The object detection's image steps on crops give the whole image's results: the table
region (closing on the inliers' box), the largest blob (opening and labels on the candidates'
box, its corner on even pixels): random masks, blobs at the image borders, tied areas."""

from __future__ import annotations

import cv2
import numpy as np

from services.tracker.objects import _largest_blob, table_region
from tests.unit.tracker.whole_cloud_reference import reference_table_region

SHAPE = (240, 320)


def _whole_image_blob(idx: np.ndarray) -> np.ndarray:
    """Largest blob's pixels (row-major), opened and labelled on the whole image."""
    cand = np.zeros(SHAPE[0] * SHAPE[1], np.uint8)
    cand[idx] = 1
    mask = cv2.morphologyEx(cand.reshape(SHAPE), cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    if n <= 1:
        return idx[:0]
    fg = idx[mask.ravel()[idx] > 0]
    blob_of = labels.ravel()[fg]
    return fg[blob_of == int(np.argmax(np.bincount(blob_of, minlength=n)[1:])) + 1]


def _random_mask(rng: np.random.Generator) -> np.ndarray:
    m = np.zeros(SHAPE, bool)
    for _ in range(int(rng.integers(1, 6))):
        r, c = rng.integers(-10, SHAPE[0]), rng.integers(-10, SHAPE[1])  # some cut by the border
        h, w = rng.integers(2, 30, 2)
        m[max(r, 0):r + h, max(c, 0):c + w] = True
    for _ in range(int(rng.integers(0, 12))):  # equal 3x3 blobs at odd and even corners
        r, c = rng.integers(0, SHAPE[0] - 3), rng.integers(0, SHAPE[1] - 3)
        m[r:r + 3, c:c + 3] = True
    m[rng.integers(0, SHAPE[0], 200), rng.integers(0, SHAPE[1], 200)] = True
    if rng.random() < 0.3:  # a small scene: only a corner of the image is used
        m[:SHAPE[0] // 2] = False
        m[:, :SHAPE[1] // 3] = False
    return m


def test_largest_blob_on_the_crop_is_the_whole_images():
    rng = np.random.default_rng(0)
    found = 0
    for _ in range(600):
        idx = np.flatnonzero(_random_mask(rng))
        if idx.size == 0:
            continue
        got = _largest_blob(idx, SHAPE)
        np.testing.assert_array_equal(got, _whole_image_blob(idx))
        found += got.size > 0
    assert found > 400


def test_table_region_on_the_crop_is_the_whole_images():
    rng = np.random.default_rng(1)
    for _ in range(300):
        m = _random_mask(rng)
        if rng.random() < 0.5:  # a table-like slab with holes
            r0, c0 = rng.integers(60, 200), rng.integers(0, 200)
            m[r0:, c0:c0 + int(rng.integers(40, 200))] = True
            m[rng.integers(0, SHAPE[0], 2000), rng.integers(0, SHAPE[1], 2000)] = False
        np.testing.assert_array_equal(table_region(m), reference_table_region(m))
    empty = np.zeros(SHAPE, bool)
    np.testing.assert_array_equal(table_region(empty), reference_table_region(empty))


def test_largest_blob_among_equal_blobs_is_the_whole_images():
    """Only equal 3x3 squares: the first in OpenCV's label order wins, and that order follows
    the 2x2 blocks OpenCV labels (why the crop's corner is on even pixels)."""
    rng = np.random.default_rng(2)
    for _ in range(600):
        m = np.zeros(SHAPE, bool)
        for _ in range(int(rng.integers(2, 6))):
            r, c = rng.integers(1, 40), rng.integers(1, 60)
            if not m[max(r - 1, 0):r + 4, max(c - 1, 0):c + 4].any():
                m[r:r + 3, c:c + 3] = True
        idx = np.flatnonzero(m)
        np.testing.assert_array_equal(_largest_blob(idx, SHAPE), _whole_image_blob(idx))
