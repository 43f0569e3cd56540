"""How a Kinect skeleton tracker gets the joints wrong.

Published figures (Kinect v1/v2 with OpenNI/NiTE): 100–150 ms latency, 50–100 mm joint
error, and a hand estimate that is dragged toward nearby objects, the robot's hand included,
because the robot merges into the person's point cloud (Mincelli et al.).

Model, per episode (seeded):
- latency L ~ U(latency range): the skeleton at time t shows the body at t − L;
- jitter: every joint gets temporally correlated noise, an AR(1) process with correlation
  time `jitter_corr_time_s` and 3-D RMS `jitter_rms_m` ~ U(jitter range);
- pull: when the (lagged) true hand is within `pull_radius_m` of the (lagged) robot hand,
  the hand estimate moves toward the robot hand by w = pull_max · (1 − d / pull_radius_m);
- dropouts: a frame is untracked with probability `dropout_probability`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bus_schema.messages import SKELETON_JOINTS

HAND_INDEX = SKELETON_JOINTS.index("right_hand")


@dataclass(frozen=True)
class SkeletonErrorParams:
    """Ranges and constants of the skeleton error model (SI units)."""

    latency_range_s: tuple[float, float] = (0.10, 0.15)
    jitter_rms_range_m: tuple[float, float] = (0.05, 0.10)
    jitter_corr_time_s: float = 0.10
    pull_radius_m: float = 0.25
    pull_max: float = 0.7
    dropout_probability: float = 0.0


class SkeletonErrorModel:
    """Turns true joint positions into the tracker's estimates (one episode).

    Args:
        params: model constants.
        rng: the episode's random generator.
    """

    def __init__(self, params: SkeletonErrorParams, rng: np.random.Generator) -> None:
        self.params = params
        self.rng = rng
        self.latency_s = float(rng.uniform(*params.latency_range_s))
        self.jitter_rms_m = float(rng.uniform(*params.jitter_rms_range_m))
        self._noise = rng.standard_normal((len(SKELETON_JOINTS), 3)) * self.jitter_rms_m / np.sqrt(3.0)
        self._t_hist: list[float] = []
        self._j_hist: list[np.ndarray] = []
        self._tool_hist: list[np.ndarray] = []
        self._last_t: float | None = None

    def _lagged(self, t_s: float) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(self._t_hist)
        target = t_s - self.latency_s
        k = int(np.searchsorted(t, target))
        if k <= 0:
            return self._j_hist[0], self._tool_hist[0]
        if k >= len(t):
            return self._j_hist[-1], self._tool_hist[-1]
        w = (target - t[k - 1]) / (t[k] - t[k - 1])
        joints = (1 - w) * self._j_hist[k - 1] + w * self._j_hist[k]
        tool = (1 - w) * self._tool_hist[k - 1] + w * self._tool_hist[k]
        return joints, tool

    def step(self, t_s: float, true_joints_m: np.ndarray,
             robot_tool_m: np.ndarray) -> tuple[bool, np.ndarray, np.ndarray]:
        """Estimate at time `t_s` (s, increasing).

        Args:
            true_joints_m: (15, 3) true joints in `SKELETON_JOINTS` order, `base`.
            robot_tool_m: (3,) true robot tool position, `base`.

        Returns:
            (tracked, estimated joints (15, 3), confidences (15,)).
        """
        if self._last_t is not None and t_s < self._last_t:
            raise ValueError(f"time went backwards: {t_s} s after {self._last_t} s")
        dt = 0.0 if self._last_t is None else t_s - self._last_t
        self._last_t = t_s
        self._t_hist.append(t_s)
        self._j_hist.append(np.array(true_joints_m, float))
        self._tool_hist.append(np.array(robot_tool_m, float))
        horizon = self.latency_s + 0.5
        while len(self._t_hist) > 2 and self._t_hist[1] < t_s - horizon:
            del self._t_hist[0], self._j_hist[0], self._tool_hist[0]
        rho = float(np.exp(-dt / self.params.jitter_corr_time_s))
        sigma = self.jitter_rms_m / np.sqrt(3.0)
        self._noise = rho * self._noise + np.sqrt(1.0 - rho * rho) * sigma * self.rng.standard_normal(self._noise.shape)
        joints, tool = self._lagged(t_s)
        est = joints + self._noise
        conf = np.ones(len(SKELETON_JOINTS))
        d = float(np.linalg.norm(joints[HAND_INDEX] - tool))
        if d < self.params.pull_radius_m:
            w = self.params.pull_max * (1.0 - d / self.params.pull_radius_m)
            est[HAND_INDEX] += w * (tool - est[HAND_INDEX])
            conf[HAND_INDEX] = 0.5
        tracked = bool(self.rng.random() >= self.params.dropout_probability)
        return tracked, est, conf
