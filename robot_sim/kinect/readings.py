"""A simulated Kinect frame's depth readings, made when something first reads them.

`KinectSim.step` returns the skeleton and the truth at once; the frame's depth image is
rendered, quantised and noised only at its first read: `DepthReadings.payload` (the
`DepthImage.depth_mm` bytes), `DepthReadings.mm` (uint16 mm) or `DepthReadings.metres`
(float32 m, NaN = no reading, what the tracker computes from the payload). Drawing the
noise of one 640 × 480 image costs about 1 ms of CPU on the 2-core machine: the tracker
reads the depth only on the object detection's frames while the receiver stands still
(every third or every 15th, `services.tracker.core.object_wanted`), so the simulated Kinect
in its process draws only those (issue 16).

A frame carries what makes its readings, so they are the same whenever it is read and
whether or not other frames were read:

- its inputs (the receiver's joints, the arm's joints, the object's position: copies), from
  which its moving shapes are made at the read (the scene renderer re-renders when frames are
  read out of order);
- its own noise generator, `KinectSim.noise_rng(index)`, seeded by the simulator's seed and
  the frame's index (a frame's noise does not depend on the draws of any other frame or of
  the skeleton's errors).

Reading the same frame again returns the same readings (they are kept).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_sim.kinect.quantise import DepthQuantiser, readings_m, readings_mm

#: Renders the frame's ideal depth: (depth (H, W) m, +inf = no hit; whether it differs from
#: the previous render's).
RenderFn = Callable[[], tuple[np.ndarray, bool]]


class DepthReadings:
    """One frame's depth readings, made at the first read.

    Args:
        render: renders the frame's ideal depth (`RenderFn`).
        quantiser: the simulator's quantiser (its buffers follow the renders).
        noise_rng: makes the frame's noise generator; None: quantisation only.
    """

    def __init__(self, render: RenderFn, quantiser: DepthQuantiser,
                 noise_rng: Callable[[], np.random.Generator] | None) -> None:
        self._render = render
        self._quantiser = quantiser
        self._noise_rng = noise_rng
        self._k: np.ndarray | None = None
        self._payload: bytes | None = None
        self.shape = quantiser.shape

    @property
    def made(self) -> bool:
        """Whether the readings were made (something read them)."""
        return self._k is not None or self._payload is not None

    def disparities(self) -> np.ndarray:
        """The frame's integer disparities (H, W) int16 (`DepthQuantiser.disparities`)."""
        if self._k is None:
            ideal_m, changed = self._render()
            rng = None if self._noise_rng is None else self._noise_rng()
            self._k = self._quantiser.disparities(ideal_m, rng, changed)
        return self._k

    @property
    def payload(self) -> bytes:
        """The `DepthImage.depth_mm` payload: uint16 mm, little-endian, 0 = no reading."""
        if self._payload is None:
            if self._k is None and self._noise_rng is None:
                # Without noise an unchanged image gives the previous payload object back.
                ideal_m, changed = self._render()
                self._payload = self._quantiser.quantise(ideal_m, None, changed)
            else:
                self._payload = readings_mm(self.disparities()).tobytes()
        return self._payload

    @property
    def mm(self) -> np.ndarray:
        """The readings (H, W) uint16 mm, 0 = no reading: a read-only view of `payload`."""
        return np.frombuffer(self.payload, "<u2").reshape(self.shape)

    def metres(self) -> np.ndarray:
        """The readings (H, W) float32 m, NaN = no reading (a new array): bit for bit what
        `services.tracker.pointcloud.depth_frame_from_message` makes of `payload`."""
        return readings_m(self.disparities())
