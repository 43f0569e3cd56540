"""Kinect v1 depth readings from ideal depth, frame after frame, into buffers kept between
frames.

`DepthQuantiser` gives byte for byte what `robot_sim.kinect.depth.kinect_depth_mm` gives
(the same values, the same random draws from the generator in the same order). The model is
the one described there: a Gaussian disparity error of σ_d ≈ 0.488 disparity steps (1/8 px),
which is σ_z = c·z² in depth to first order, then the integer disparity k gives the reading
f·b / (k·step) in millimetres. Per frame, with noise, only 16-bit and 32-bit passes remain:

- one uniform uint16 per pixel (`rng.integers`), turned into σ_d·N by a float32 table of
  Gaussian quantiles (`depth.DISPARITY_NOISE_TABLE_STEPS`; tails truncated at about 4.3 σ),
  instead of a float64 `standard_normal` (which cost ~0.74 ms a frame);
- the ideal disparity + 0.5 (steps, float32) is kept per ideal image; added to the noise and
  cast to int16 it is k = round(d + σ_d·N) (the sum is > 0, so the cast floors);
- k indexes `_READING_MM`, the reading (uint16 mm) of each disparity, 0 where that reading is
  outside the sensor's range. Pixels whose ideal depth is out of range get a sentinel
  disparity whose k stays in 1..6, all of which read 0: no mask per frame, and every index
  is inside the table (in-range depths are ≥ 0.5 m, so k ≤ 687);
- dropouts, independent Bernoulli(p) per pixel, are drawn sparsely: their number
  K ~ Binomial(n, p), then K distinct pixels (`rng.choice`), whose k is set to 0 (k = 0
  reads 0).

`DepthQuantiser.disparities` gives a frame's k (a new int16 array, the frame's own);
`readings_mm` turns it into the payload's uint16 millimetres and `readings_m` straight into
the float32 metres (NaN = no reading) the tracker computes from the payload, one table pass
each, so a consumer in the same process needs no bytes. The per-image work (range test,
disparities, sentinel) is done only for a new ideal image, without masked writes. Without
noise, an unchanged ideal image gives the previous payload back (no work). The payload is
the image as little-endian uint16 bytes (`bus_schema.messages.DepthImage`).
"""

from __future__ import annotations

import numpy as np

from robot_sim.kinect import camera as cam
from robot_sim.kinect.depth import DISPARITY_DEPTH_STEPS_M, DISPARITY_NOISE_TABLE_STEPS, NOISE_TABLE_SIZE

#: Disparity (steps) given to pixels whose ideal depth is out of range: rint gives k = 4,
#: and 3.5 + 0.5 ± 2.11 (the table's extremes) floors to 1..6. Those disparities read
#: 342.6 / k ≥ 57 m, out of range: 0.
_SENTINEL_STEPS = 3.5


def _reading_table_mm() -> np.ndarray:
    """Reading (uint16 mm, 0 = out of range) of each integer disparity k (steps), with the
    operations of `kinect_depth_mm`, over every k an in-range depth plus noise can reach."""
    d_max = np.float32(DISPARITY_DEPTH_STEPS_M / cam.KINECT_MIN_RANGE_M + 0.5)
    k = np.arange(int(d_max + DISPARITY_NOISE_TABLE_STEPS.max()) + 2, dtype=float)
    zq = DISPARITY_DEPTH_STEPS_M / np.maximum(k, 1.0)
    valid = (zq >= cam.KINECT_MIN_RANGE_M) & (zq <= cam.KINECT_MAX_RANGE_M)
    table = np.where(valid, np.round(zq * 1000.0), 0).astype(np.uint16)
    table.flags.writeable = False
    return table


_READING_MM = _reading_table_mm()


def _reading_table_m() -> np.ndarray:
    """`_READING_MM` as the tracker reads it: float32 metres (mm × float32 0.001), NaN for 0."""
    table = _READING_MM.astype(np.float32) * np.float32(0.001)
    table[_READING_MM == 0] = np.nan
    table.flags.writeable = False
    return table


_READING_M = _reading_table_m()


class DepthQuantiser:
    """Turns ideal depth images (m, +inf = no hit) of one size into Kinect v1 readings.

    Args:
        shape: (H, W) of the images.
        dropout_fraction: probability that a pixel has no reading (with noise only, as
            `kinect_depth_mm`).
    """

    def __init__(self, shape: tuple[int, int], dropout_fraction: float = 0.005) -> None:
        self.shape = shape
        self.dropout_fraction = float(dropout_fraction)
        self._in_range = np.empty(shape, bool)  # of the last ideal image
        self._cond = np.empty(shape, bool)
        self._d_steps = np.empty(shape)  # ideal disparity (steps), the sentinel out of range
        self._d_half_steps = np.empty(shape, np.float32)  # the same + 0.5, float32
        self._noise_steps = np.empty(shape, np.float32)
        self._payload: bytes | None = None  # of the last noise-free image
        self._primed = False

    def _take_ideal(self, depth_m: np.ndarray) -> None:
        """Disparities of a new ideal image (the sentinel where it is out of range)."""
        if depth_m.shape != self.shape:
            raise ValueError(f"depth image is {depth_m.shape}, the quantiser is for {self.shape}")
        valid, d = self._in_range, self._d_steps
        # In range (NaN and ±inf fail a comparison). No masked writes: they cost ~10× a pass
        # on a ragged mask. fmax makes every depth ≥ 0.5 m (NaN too) and leaves in-range ones
        # as they are, so the division is finite; × valid zeroes the out-of-range pixels,
        # which the maximum lifts to the sentinel (in-range disparities are ≥ 76 steps).
        np.greater_equal(depth_m, cam.KINECT_MIN_RANGE_M, out=valid)
        valid &= np.less_equal(depth_m, cam.KINECT_MAX_RANGE_M, out=self._cond)
        np.fmax(depth_m, cam.KINECT_MIN_RANGE_M, out=d)
        np.divide(DISPARITY_DEPTH_STEPS_M, d, out=d)
        np.multiply(d, valid, out=d)
        np.maximum(d, _SENTINEL_STEPS, out=d)
        np.add(d, 0.5, out=self._d_half_steps, casting="same_kind")
        self._primed = True
        self._payload = None

    def disparities(self, depth_m: np.ndarray, rng: np.random.Generator | None, changed: bool = True) -> np.ndarray:
        """The frame's integer disparities k (H, W) int16, a new array: `readings_mm` and
        `readings_m` give its readings. Dropouts get k = 0, which reads 0 (no reading).

        Args:
            depth_m: ideal depths (H, W), m.
            rng: noise and dropouts; None: quantisation only.
            changed: False when `depth_m` holds the same values as at the previous call
                (the caller knows: `SceneDepthRenderer.changed`), which skips the per-image
                work.
        """
        if changed or not self._primed:
            self._take_ideal(depth_m)
        k = np.empty(self.shape, np.int16)
        if rng is None:
            np.rint(self._d_steps, out=k, casting="unsafe")
            return k
        u = rng.integers(0, NOISE_TABLE_SIZE, size=self.shape, dtype=np.uint16)
        noise = np.take(DISPARITY_NOISE_TABLE_STEPS, u, out=self._noise_steps)
        noise += self._d_half_steps
        np.copyto(k, noise, casting="unsafe")  # > 0: truncation is floor
        if self.dropout_fraction > 0.0:
            n = k.size
            k.reshape(-1)[rng.choice(n, rng.binomial(n, self.dropout_fraction), replace=False)] = 0
        return k

    def quantise(self, depth_m: np.ndarray, rng: np.random.Generator | None, changed: bool = True) -> bytes:
        """Readings of `depth_m` as the `DepthImage.depth_mm` payload (uint16 mm, little-endian,
        0 = no reading); arguments as `disparities`. Without noise, an unchanged image gives
        the previous payload object back (no work)."""
        if rng is None and not changed and self._primed and self._payload is not None:
            return self._payload
        payload = readings_mm(self.disparities(depth_m, rng, changed)).tobytes()
        if rng is None:
            self._payload = payload
        return payload


def readings_mm(k: np.ndarray) -> np.ndarray:
    """Readings (uint16 mm, little-endian, 0 = no reading) of disparities k (`DepthQuantiser.disparities`)."""
    return np.take(_READING_MM, k)


def readings_m(k: np.ndarray) -> np.ndarray:
    """Readings (float32 m, NaN = no reading) of disparities k: bit for bit what
    `services.tracker.pointcloud.depth_frame_from_message` makes of `readings_mm(k)`, in
    one pass and without the bytes."""
    return np.take(_READING_M, k)
