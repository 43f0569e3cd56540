"""Kinect v1 depth readings from ideal depth, frame after frame, into buffers kept between
frames.

`DepthQuantiser` gives byte for byte what `robot_sim.kinect.depth.kinect_depth_mm` gives
(the same operations in the same order, the same random draws from the generator in the
same order), but

- each step writes into an array allocated once (a fresh 600 kB temporary per step used to
  cost more than the arithmetic: page faults);
- the range mask of the ideal depth is worked out once per new ideal image;
- without noise, an unchanged ideal image gives the previous payload back (no work).

The payload is the image as little-endian uint16 bytes (`bus_schema.messages.DepthImage`).
"""

from __future__ import annotations

import numpy as np

from robot_sim.kinect import camera as cam
from robot_sim.kinect.depth import DEPTH_NOISE_COEFF_PER_M

_FB = cam.KINECT_FULL_RES_FOCAL_PX * cam.KINECT_BASELINE_M
_STEP = cam.KINECT_DISPARITY_STEP_PX


class DepthQuantiser:
    """Turns ideal depth images (m, +inf = no hit) of one size into Kinect v1 readings.

    Args:
        shape: (H, W) of the images.
        dropout_fraction: fraction of pixels with no reading (with noise only, as
            `kinect_depth_mm`).
    """

    def __init__(self, shape: tuple[int, int], dropout_fraction: float = 0.005) -> None:
        self.shape = shape
        self.dropout_fraction = float(dropout_fraction)
        self._in_range = np.empty(shape, bool)  # of the last ideal image
        self._zv = np.empty(shape)  # the last ideal image, 1.0 out of range
        self._valid = np.empty(shape, bool)
        self._cond = np.empty(shape, bool)
        self._z = np.empty(shape)
        self._noise = np.empty(shape)
        self._mm = np.empty(shape)
        self._out = np.empty(shape, "<u2")
        self._payload: bytes | None = None  # of the last noise-free image
        self._primed = False

    def _take_ideal(self, depth_m: np.ndarray) -> None:
        """Range mask and range-clamped depths of a new ideal image."""
        if depth_m.shape != self.shape:
            raise ValueError(f"depth image is {depth_m.shape}, the quantiser is for {self.shape}")
        valid, cond = self._in_range, self._cond
        np.isfinite(depth_m, out=valid)
        valid &= np.greater_equal(depth_m, cam.KINECT_MIN_RANGE_M, out=cond)
        valid &= np.less_equal(depth_m, cam.KINECT_MAX_RANGE_M, out=cond)
        self._zv.fill(1.0)
        np.copyto(self._zv, depth_m, where=valid)
        self._primed = True
        self._payload = None

    def quantise(self, depth_m: np.ndarray, rng: np.random.Generator | None, changed: bool = True) -> bytes:
        """Readings of `depth_m` as the `DepthImage.depth_mm` payload (uint16 mm, little-endian,
        0 = no reading).

        Args:
            depth_m: ideal depths (H, W), m.
            rng: noise and dropouts; None: quantisation only.
            changed: False when `depth_m` holds the same values as at the previous call
                (the caller knows: `SceneDepthRenderer.changed`), which skips the range mask
                and, without noise, the whole work.
        """
        if changed or not self._primed:
            self._take_ideal(depth_m)
        elif rng is None and self._payload is not None:
            return self._payload
        z, valid, cond = self._zv, self._valid, self._cond
        np.copyto(valid, self._in_range)
        if rng is not None:
            # zv + N · c · zv · zv, left to right as in kinect_depth_mm.
            noise = rng.standard_normal(out=self._noise)
            noise *= DEPTH_NOISE_COEFF_PER_M
            noise *= z
            noise *= z
            z = np.add(self._zv, noise, out=self._z)
            np.maximum(z, 1e-3, out=z)
        disparity, zq = self._mm, self._noise
        np.divide(_FB, z, out=disparity)
        disparity /= _STEP
        np.round(disparity, out=disparity)
        disparity *= _STEP
        np.maximum(disparity, _STEP, out=disparity)
        np.divide(_FB, disparity, out=zq)
        mm = np.multiply(zq, 1000.0, out=self._mm)
        np.round(mm, out=mm)
        if rng is not None and self.dropout_fraction > 0.0:
            drop_draw = rng.random(out=self._z)
            valid &= np.greater_equal(drop_draw, self.dropout_fraction, out=cond)
        valid &= np.greater_equal(zq, cam.KINECT_MIN_RANGE_M, out=cond)
        valid &= np.less_equal(zq, cam.KINECT_MAX_RANGE_M, out=cond)
        self._out.fill(0)
        np.copyto(self._out, mm, casting="unsafe", where=valid)
        payload = self._out.tobytes()
        if rng is None:
            self._payload = payload
        return payload
