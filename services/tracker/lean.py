"""Lean stand-ins for the numpy routines the tracker runs on every frame: the same result,
bit for bit, with less work (fewer passes, fewer temporaries, less Python around them).

Each function names the numpy expression it replaces; `tests/unit/tracker/test_lean_numeric.py`
compares them with numpy on random and adversarial inputs. Inputs they were not written for
(NaN, empty, other dtypes) go to numpy itself.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def histogram_mode(values: np.ndarray, bins: int, first_edge: float, last_edge: float) -> tuple[int, np.ndarray]:
    """`k = argmax(counts)` and `edges` of `counts, edges = np.histogram(values, bins,
    range=(first_edge, last_edge))`, for float32 `values` (N,) inside the range.

    numpy guesses each value's bin from its offset and moves it by one where the guess
    disagrees with the edges, so a value in bin i is the one with edges[i] <= v < edges[i+1]
    (the last bin also holds the last edge). This takes the guess in float32 and applies the
    same two comparisons, then counts with `np.bincount`: fewer passes than numpy's float64
    ones and no boolean-mask assignments.
    """
    v = np.asarray(values)
    if (v.dtype != np.float32 or v.ndim != 1 or v.size == 0 or bins < 1
            or not np.isfinite(first_edge) or not np.isfinite(last_edge) or not first_edge < last_edge):
        counts, edges = np.histogram(v, bins=bins, range=(first_edge, last_edge))
        return int(np.argmax(counts)), edges
    edges = np.linspace(first_edge, last_edge, bins + 1, endpoint=True, dtype=np.result_type(first_edge, last_edge, v))
    if np.any(edges[:-1] >= edges[1:]) or not (edges[0] <= v.min() and v.max() <= edges[-1]):
        counts, edges = np.histogram(v, bins=bins, range=(first_edge, last_edge))
        return int(np.argmax(counts)), edges
    scale = np.float32(bins / (last_edge - first_edge))
    index = ((v - edges[0]) * scale).astype(np.int32)  # a guess in 0 .. bins
    np.minimum(index, bins - 1, out=index)
    index -= v < np.take(edges, index)  # numpy's two corrections, on the same edges
    index += (v >= np.take(edges, index + 1)) & (index != bins - 1)
    return int(np.argmax(np.bincount(index, minlength=bins))), edges


def percentiles(values: np.ndarray, q: Sequence[float]) -> np.ndarray:
    """`np.percentile(values, q, axis=0)` (method "linear") for float64 `values` (N, k):
    shape (len(q), k).

    The same steps as numpy's `_quantile` (virtual index (n-1) q, the same partition call with
    the same kth list, the same two-sided interpolation), without its generic machinery.
    """
    arr = np.asarray(values)
    if arr.dtype != np.float64 or arr.ndim != 2 or arr.shape[0] == 0:
        return np.asarray(np.percentile(arr, q, axis=0))
    n = arr.shape[0]
    quantiles = np.true_divide(np.asarray(q, dtype=np.float64), np.float64(100))
    virtual = (n - 1) * quantiles
    previous = np.floor(virtual)
    following = previous + 1
    above = virtual >= n - 1
    previous[above] = -1
    following[above] = -1
    below = virtual < 0
    previous[below] = 0
    following[below] = 0
    previous_i, following_i = previous.astype(np.intp), following.astype(np.intp)
    part = np.partition(arr, np.unique(np.concatenate(([0, -1], previous_i, following_i))), axis=0)
    if np.isnan(part[-1]).any():
        return np.asarray(np.percentile(arr, q, axis=0))
    gamma = np.asarray(virtual - previous_i, dtype=np.float64).reshape(-1, 1)
    a, b = part[previous_i], part[following_i]
    diff_b_a = np.subtract(b, a)
    out = np.add(a, diff_b_a * gamma)
    np.subtract(b, diff_b_a * (1 - gamma), out=out, where=gamma >= 0.5)
    return out


def median_rows(values: np.ndarray) -> np.ndarray:
    """`np.median(values, axis=0)` for float64 `values` (n, k), n >= 1: numpy's `_median`
    steps (the same partition call with the same kth list, the same mean of the middle one or
    two rows, NaN where a column holds one) without `_ureduce` around them."""
    arr = np.asarray(values)
    if arr.dtype != np.float64 or arr.ndim != 2 or arr.shape[0] == 0:
        return np.asarray(np.median(arr, axis=0))
    n = arr.shape[0]
    kth = [n // 2 - 1, n // 2, -1] if n % 2 == 0 else [(n - 1) // 2, -1]
    part = np.partition(arr, kth, axis=0)
    index = n // 2
    middle = part[index:index + 1] if n % 2 == 1 else part[index - 1:index + 1]
    result = np.mean(middle, axis=0)
    last = part[-1]
    nan = np.isnan(last)
    if nan.any():
        np.copyto(result, last, where=nan)
    return result


def row_norms(d: np.ndarray) -> np.ndarray:
    """`[np.linalg.norm(row) for row in d]` for float64 rows d (N, k): numpy's norm of a
    vector is `sqrt(x.dot(x))` and `np.vecdot` takes each row's dot with the same BLAS dot."""
    rows = np.asarray(d)
    if rows.dtype != np.float64 or rows.ndim != 2:
        return np.array([np.linalg.norm(r) for r in rows])
    return np.sqrt(np.vecdot(rows, rows))


def vector_norm(v: np.ndarray) -> float:
    """`float(np.linalg.norm(v))` for a float64 vector v (k,) (the same `sqrt(v.dot(v))`)."""
    x = np.asarray(v)
    if x.dtype != np.float64 or x.ndim != 1:
        return float(np.linalg.norm(x))
    return float(np.sqrt(x.dot(x)))


class RowWindow:
    """The last `capacity` rows of `width` floats, readable as one contiguous array in the
    order they came (oldest first), without stacking them every time.

    Each row is written twice, at i and i + capacity of a (2 capacity, width) buffer, so the
    last n rows are always the slice that ends at the newest copy. `rows()` gives exactly
    `np.stack(deque_of_the_same_rows)` (values, order and strides), read-only.
    """

    def __init__(self, capacity: int, width: int) -> None:
        if capacity < 1 or width < 1:
            raise ValueError("need capacity >= 1 and width >= 1")
        self.capacity = capacity
        self._buf = np.zeros((2 * capacity, width))
        self._next = 0  # where the next row goes (0 .. capacity-1)
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def append(self, row: np.ndarray) -> None:
        """Add a row (width,), dropping the oldest one when full."""
        i = self._next
        self._buf[i] = row
        self._buf[i + self.capacity] = row
        self._next = (i + 1) % self.capacity
        self._count = min(self._count + 1, self.capacity)

    def clear(self) -> None:
        self._next = 0
        self._count = 0

    def rows(self) -> np.ndarray:
        """The rows (n, width), oldest first: a read-only view, valid until the next append."""
        end = self._next + self.capacity
        view = self._buf[end - self._count:end]
        view.flags.writeable = False
        return view
