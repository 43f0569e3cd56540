"""The lean numeric helpers (`services.tracker.lean`) give numpy's results bit for bit: random
inputs, values on and next to bin edges, ties, signed zeros, NaN, the sizes the tracker sees."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from services.tracker.lean import RowWindow, histogram_mode, median_rows, percentiles, row_norms, vector_norm


def assert_bitwise(got, ref) -> None:
    got, ref = np.asarray(got), np.asarray(ref)
    assert got.dtype == ref.dtype and got.shape == ref.shape
    assert got.tobytes() == ref.tobytes(), (got, ref)


def _reference_mode(values: np.ndarray, bins: int, lo: float, hi: float):
    counts, edges = np.histogram(values, bins=bins, range=(lo, hi))
    return int(np.argmax(counts)), edges


def _lean_mode(monkeypatch, values: np.ndarray, bins: int, lo: float, hi: float):
    """`histogram_mode` on its own path (numpy's histogram would raise)."""
    with monkeypatch.context() as m:
        m.setattr(np, "histogram", lambda *a, **k: pytest.fail("histogram_mode fell back to numpy"))
        return histogram_mode(values, bins, lo, hi)


def _table_heights(rng: np.random.Generator, n: int) -> np.ndarray:
    """Heights (float32) like the table-plane candidates: a table, a person, a robot, clutter."""
    parts = [rng.normal(-0.2, 0.004, n // 2), rng.uniform(-0.6, 1.0, n // 3), rng.normal(0.3, 0.1, n // 6 + 1)]
    return np.concatenate(parts).astype(np.float32)


def test_histogram_mode_is_numpys_on_table_heights(monkeypatch):
    rng = np.random.default_rng(0)
    for _ in range(300):
        z = _table_heights(rng, int(rng.integers(1, 40_000)))
        width = float(rng.choice([0.01, 0.005, 0.02, 0.0137]))
        lo = float(np.min(z))
        bins = max(1, int(np.ceil((float(np.max(z)) - lo) / width)) + 1)
        k, edges = _lean_mode(monkeypatch, z, bins, lo, lo + bins * width)
        k_ref, edges_ref = _reference_mode(z, bins, lo, lo + bins * width)
        assert k == k_ref
        assert_bitwise(edges, edges_ref)


def test_histogram_mode_on_and_next_to_the_edges(monkeypatch):
    """Values exactly on the float32 edges and one ulp either side (where a bin guess from the
    offset is off by one), the last edge itself, ties between bins (the first wins)."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        lo, width = float(np.float32(rng.uniform(-1.0, 1.0))), float(rng.choice([0.01, 0.003, 0.1]))
        bins = int(rng.integers(1, 200))
        edges = np.linspace(lo, lo + bins * width, bins + 1, dtype=np.float32)
        pick = edges[rng.integers(0, bins + 1, 3000)]
        values = np.concatenate([pick, np.nextafter(pick, np.float32(np.inf)), np.nextafter(pick, np.float32(-np.inf)),
                                 np.repeat(edges[rng.integers(0, bins, 2)], 50)]).astype(np.float32)
        values = values[(values >= edges[0]) & (values <= edges[-1])]
        rng.shuffle(values)
        k, got_edges = _lean_mode(monkeypatch, values, bins, lo, lo + bins * width)
        k_ref, ref_edges = _reference_mode(values, bins, lo, lo + bins * width)
        assert k == k_ref
        assert_bitwise(got_edges, ref_edges)


def test_histogram_mode_leaves_other_inputs_to_numpy():
    values = np.array([0.0, 0.25, 0.5, 2.0, -1.0], dtype=np.float32)  # outside the range: numpy drops them
    assert histogram_mode(values, 4, 0.0, 1.0)[0] == _reference_mode(values, 4, 0.0, 1.0)[0]
    values64 = values.astype(float)  # another dtype: numpy's own histogram
    assert histogram_mode(values64, 4, 0.0, 1.0)[0] == _reference_mode(values64, 4, 0.0, 1.0)[0]


@pytest.mark.parametrize("q", [[2, 98], [98], [0, 50, 100], [2.5, 97.5], [33]])
def test_percentiles_are_numpys(q):
    rng = np.random.default_rng(2)
    for n in list(range(1, 30)) + [100, 349, 350, 1000, 4321]:
        for k in (1, 2, 3):
            values = rng.normal(0.5, 0.05, (n, k)).astype(np.float32).astype(float)
            if rng.random() < 0.3:
                values = np.round(values, 2)  # ties
            assert_bitwise(percentiles(values, q), np.percentile(values, q, axis=0))
            assert_bitwise(percentiles(values[:, :1], q)[:, 0], np.percentile(values[:, 0], q))
    strided = rng.normal(size=(200, 3))[:, :2]  # as detect_object passes the points' x, y
    assert_bitwise(percentiles(strided, [2, 98]), np.percentile(strided, [2, 98], axis=0))
    with_nan = rng.normal(size=(50, 2))
    with_nan[7, 1] = np.nan
    assert_bitwise(percentiles(with_nan, [2, 98]), np.percentile(with_nan, [2, 98], axis=0))


def test_median_rows_is_numpys():
    rng = np.random.default_rng(3)
    for n in list(range(1, 40)) + [89, 90, 91, 200]:
        values = rng.normal(0.0, 1.0, (n, 7))
        values[rng.random((n, 7)) < 0.1] = 0.0
        values[rng.random((n, 7)) < 0.1] = -0.0
        if rng.random() < 0.3:
            values = np.round(values, 1)  # ties
        if rng.random() < 0.3:
            values[rng.integers(n), rng.integers(7)] = np.nan
        if rng.random() < 0.2:
            values[rng.integers(n), rng.integers(7)] = -np.inf
        assert_bitwise(median_rows(values), np.median(values, axis=0))


def test_norms_are_numpys():
    rng = np.random.default_rng(4)
    d = rng.normal(size=(20_000, 3)) * 10.0 ** rng.uniform(-4, 2, (20_000, 1))
    ref = np.array([np.linalg.norm(v) for v in d])
    assert_bitwise(row_norms(d), ref)  # numpy's vector norm is a BLAS dot (fused multiply-adds)
    assert all(vector_norm(v) == np.linalg.norm(v) for v in d[:2000])
    single = d[:100].astype(np.float32)  # not float64: numpy's norm itself
    assert_bitwise(row_norms(single), np.array([np.linalg.norm(v) for v in single]))
    assert vector_norm(single[0]) == float(np.linalg.norm(single[0]))


@pytest.mark.parametrize("capacity", [1, 2, 15, 90])
def test_row_window_is_the_stack_of_the_last_rows(capacity):
    rng = np.random.default_rng(capacity)
    window, ref = RowWindow(capacity, 7), deque(maxlen=capacity)
    for step in range(5 * capacity + 20):
        if rng.random() < 0.03:
            window.clear()
            ref.clear()
        row = rng.normal(size=7)
        window.append(row)
        ref.append(row.copy())
        rows = window.rows()
        stacked = np.stack(ref)
        assert_bitwise(rows, stacked)
        assert rows.strides == stacked.strides and len(window) == len(ref)
        assert_bitwise(np.var(rows[:, 1]), np.var(stacked[:, 1]))  # summation order kept
        assert not rows.flags.writeable
