"""Statistics of the simulated Kinect's depth readings: disparity noise of the size
Khoshelham & Elberink give (σ_z ≈ c·z²), unbiased means, Bernoulli dropouts spread over the
image, no reading out of range, and the noise-free quantisation of the earlier model."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.kinect import camera as cam
from robot_sim.kinect.depth import (
    DEPTH_NOISE_COEFF_PER_M,
    DISPARITY_DEPTH_STEPS_M,
    DISPARITY_NOISE_STEPS,
    DISPARITY_NOISE_TABLE_STEPS,
    kinect_depth_mm,
)
from robot_sim.kinect.quantise import DepthQuantiser

SHAPE = (60, 80)


def _readings_m(depth_m: np.ndarray, frames: int, dropout_fraction: float = 0.0, seed: int = 1) -> np.ndarray:
    """Readings (frames, H, W) in m of the same ideal image, frame after frame, with noise."""
    quantiser = DepthQuantiser(depth_m.shape, dropout_fraction)
    rng = np.random.default_rng(seed)
    return np.stack([np.frombuffer(quantiser.quantise(depth_m, rng, changed=k == 0), "<u2").reshape(depth_m.shape)
                     for k in range(frames)]).astype(float) / 1000.0


def _direct_readings_m(z_m: float, sigma_steps: float, n: int) -> np.ndarray:
    """The disparity model in float64 with numpy's normal draws: round(d + σ·N) steps."""
    k = np.round(DISPARITY_DEPTH_STEPS_M / z_m + sigma_steps * np.random.default_rng(7).standard_normal(n))
    return np.round(1000.0 * DISPARITY_DEPTH_STEPS_M / k) / 1000.0


def _old_noise_free_mm(depth_m: np.ndarray) -> np.ndarray:
    """The noise-free readings of the earlier model (git HEAD before the disparity noise)."""
    z = np.array(depth_m, dtype=float)
    valid = np.isfinite(z) & (z >= cam.KINECT_MIN_RANGE_M) & (z <= cam.KINECT_MAX_RANGE_M)
    zv = np.where(valid, z, 1.0)
    fb = cam.KINECT_FULL_RES_FOCAL_PX * cam.KINECT_BASELINE_M
    disparity = np.round(fb / zv / cam.KINECT_DISPARITY_STEP_PX) * cam.KINECT_DISPARITY_STEP_PX
    zq = fb / np.maximum(disparity, cam.KINECT_DISPARITY_STEP_PX)
    valid &= (zq >= cam.KINECT_MIN_RANGE_M) & (zq <= cam.KINECT_MAX_RANGE_M)
    return np.where(valid, np.round(zq * 1000.0), 0).astype(np.uint16)


def test_noise_table_is_a_standard_normal_times_sigma_d():
    table = DISPARITY_NOISE_TABLE_STEPS.astype(float)
    assert DISPARITY_NOISE_STEPS == pytest.approx(0.488, abs=1e-3)
    assert table.mean() == pytest.approx(0.0, abs=1e-9)
    assert table.std() == pytest.approx(DISPARITY_NOISE_STEPS, rel=2e-3)
    assert np.all(np.diff(table) >= 0.0)  # quantiles, in order
    assert np.abs(table).max() == pytest.approx(4.32 * DISPARITY_NOISE_STEPS, rel=2e-3)  # tails cut at 4.3 σ


@pytest.mark.parametrize("z_m", [1.0, 2.0, 3.5])
def test_depth_noise_has_the_spread_of_the_disparity_model_and_no_bias(z_m):
    readings = _readings_m(np.full(SHAPE, z_m), frames=200)
    assert np.all(readings > 0.0)
    got = readings.std()
    first_order = DEPTH_NOISE_COEFF_PER_M * z_m * z_m  # σ_z = c·z²
    # The same model in float64 with numpy normals: equal within 3 % (sampling: 0.1 %). A σ_d
    # twice or half as large would be ≥ 14 % off: checked here so the bound stays telling.
    want = _direct_readings_m(z_m, DISPARITY_NOISE_STEPS, readings.size).std()
    assert got == pytest.approx(want, rel=0.03)
    for wrong in (2.0 * DISPARITY_NOISE_STEPS, 0.5 * DISPARITY_NOISE_STEPS):
        assert abs(_direct_readings_m(z_m, wrong, readings.size).std() / want - 1.0) > 0.14
    # Analytic: c·z² widened by the rounding to whole steps, √(1 + 1/(12 σ_d²)) ≈ 1.16.
    assert 1.05 * first_order < got < 1.35 * first_order
    # Unbiased: the noise dithers the disparity steps; what is left is the millimetre rounding.
    step_m = z_m * z_m / DISPARITY_DEPTH_STEPS_M  # one disparity step in depth
    assert abs(readings.mean() - z_m) < 0.1 * step_m + 0.0005


def test_dropouts_are_bernoulli_per_pixel_and_spread_over_the_image():
    p, frames = 0.02, 100
    readings = _readings_m(np.full((120, 160), 2.0), frames, dropout_fraction=p)
    dropped = readings == 0.0  # at 2 m every reading is in range: zeros are dropouts
    n = dropped.size
    assert abs(dropped.sum() - n * p) < 4.0 * np.sqrt(n * p * (1 - p))
    h, w = dropped.shape[1:]
    for rows in (slice(0, h // 2), slice(h // 2, h)):
        for cols in (slice(0, w // 2), slice(w // 2, w)):
            part = dropped[:, rows, cols]
            assert abs(part.sum() - part.size * p) < 4.0 * np.sqrt(part.size * p * (1 - p)), (rows, cols)
    # The number per frame varies as a binomial's (n p (1 − p) ≈ 376; sample variance ± 14 %).
    per_frame = dropped.sum(axis=(1, 2))
    assert 0.6 < per_frame.var(ddof=1) / (h * w * p * (1 - p)) < 1.5
    # Fresh pixels each frame: two frames share about K·p of their K dropouts.
    shared = (dropped[1:] & dropped[:-1]).sum(axis=(1, 2)).mean()
    assert shared < 3.0 * per_frame.mean() * p


@pytest.mark.parametrize("noise", [True, False])
def test_out_of_range_depths_read_nothing(noise):
    outside = np.array([0.3, 0.4999, 4.5001, 5.0, np.inf, -np.inf, np.nan, 0.0, -1.0])
    depth = np.tile(outside, (40, 1))
    frames = 50 if noise else 1
    for seed in range(frames):
        rng = np.random.default_rng(seed) if noise else None
        assert not kinect_depth_mm(depth, rng, 0.0).any()
    readings = _readings_m(depth, frames) if noise else np.frombuffer(
        DepthQuantiser(depth.shape).quantise(depth, None), "<u2")
    assert not readings.any()


def test_range_edges_read_within_the_range_with_noise():
    depth = np.tile([cam.KINECT_MIN_RANGE_M, cam.KINECT_MAX_RANGE_M], (50, 20))
    readings = _readings_m(depth, 100)  # in-range disparity + noise stays inside the table
    # 0.5 m is 685.2 steps, 4.5 m 76.1 steps: noisy readings past the range read 0.
    for edge, lo_m, hi_m in ((readings[..., 0::2], 0.5, 0.503), (readings[..., 1::2], 4.39, 4.5)):
        assert np.all((edge == 0.0) | ((edge >= lo_m) & (edge <= hi_m)))
        assert 0.1 < np.mean(edge > 0.0) < 0.9  # 0.73 and 0.23


def test_noise_free_readings_are_the_earlier_quantisation():
    depth = np.concatenate([np.linspace(0.45, 4.6, 400_000), [0.5, 4.5, np.inf, np.nan, 0.0]]).reshape(5, -1)
    want = _old_noise_free_mm(depth)
    np.testing.assert_array_equal(kinect_depth_mm(depth, None), want)
    got = DepthQuantiser(depth.shape).quantise(depth, None)
    assert got == want.astype("<u2").tobytes()
    assert kinect_depth_mm(np.full((1, 1), 2.0), None)[0, 0] == 2004  # 21.375 px of disparity
