"""The simulated Kinect of the sim backend, on its own thread at 30 Hz.

Rendering a depth frame takes ~15 ms, longer than the arm's 10 ms servo tick, so it runs
beside the 100 Hz loop: each frame reads the latest arm posture (a snapshot handed over by
the loop), renders skeleton and depth with `robot_sim.kinect.KinectSim`, and publishes
`perception/skeleton` and `perception/depth`. numpy releases the GIL in the heavy parts, so
the servo loop keeps its rate.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np

from bus_schema import topics
from services.bridge.config import KinectConfig
from services.runtime import RateLimitedLog

log = logging.getLogger(__name__)


class KinectThread:
    """Publishes simulated skeleton and depth frames until `stop()`."""

    def __init__(self, config: KinectConfig, node: Any) -> None:
        from robot_sim.kinect import KinectScenario, KinectSim

        target = tuple(config.hand_target_base_m) if config.hand_target_base_m else None
        scenario = KinectScenario(height_m=config.height_m, posture=config.posture,
                                  hand_target_base_m=target, reach_start_s=config.reach_start_s,
                                  reach_duration_s=config.reach_duration_s)
        self.sim = KinectSim(config.seed, scenario)
        self.period_s = 1.0 / config.rate_hz
        self._skeleton = node.publisher(topics.SKELETON)
        self._depth = node.publisher(topics.DEPTH)
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._q_arm: np.ndarray | None = None
        self._hand: np.ndarray | None = None
        self._object: np.ndarray | None = None
        self._errors = RateLimitedLog(log, 5.0)
        self.frames = 0
        self._truth: dict[str, tuple[float, float, float]] = {}
        self._truth_pub = None
        self._thread = threading.Thread(target=self._run, name="kinect", daemon=True)

    def publish_own_truth(self, node: Any) -> None:
        """Publish `sim/truth` from this thread (when no contact plant publishes it)."""
        self._truth_pub = node.publisher(topics.SIM_TRUTH)

    def truth_fields(self) -> dict[str, tuple[float, float, float]]:
        """The latest frame's ground truth as `SimTruth` fields (empty before the first)."""
        with self._lock:
            return dict(self._truth)

    def update_arm(self, q_rad: np.ndarray, hand_m: np.ndarray | None = None,
                   object_m: np.ndarray | None = None) -> None:
        """Hand over the arm's latest joint positions (rad) and, when a handover scene drives
        the receiver, its right hand and the object (m, `base`) (called by the 100 Hz loop)."""
        with self._lock:
            self._q_arm = q_rad.copy()
            self._hand = None if hand_m is None else hand_m.copy()
            self._object = None if object_m is None else object_m.copy()

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)

    def _run(self) -> None:
        t0 = time.monotonic()
        next_frame = t0
        while not self._stop.is_set():
            with self._lock:
                q = None if self._q_arm is None else self._q_arm.copy()
                hand, obj = self._hand, self._object
            if q is not None:
                try:
                    frame = self.sim.step(time.monotonic() - t0, q, object_position_m=obj, right_hand_m=hand)
                    self._skeleton.put(**frame.skeleton_fields)
                    self._depth.put(**frame.depth_fields)
                    self.frames += 1
                    truth = {
                        "kinect_hand_truth_m": tuple(np.clip(frame.truth.right_hand_m, -100, 100).tolist()),
                        "kinect_torso_truth_m": tuple(np.clip(frame.truth.joints_m["torso"], -100, 100).tolist()),
                    }
                    with self._lock:
                        self._truth = truth
                    if self._truth_pub is not None:
                        self._truth_pub.put(held_by="gripper",
                                            tool_position_m=tuple(frame.truth.robot_tool_m.tolist()),
                                            **truth)
                except Exception as exc:  # a bad frame must not kill the bridge
                    self._errors.warning("kinect", f"simulated Kinect frame failed: {exc!r}")
            next_frame += self.period_s
            delay = next_frame - time.monotonic()
            if delay < 0:
                next_frame = time.monotonic()  # late: do not burst to catch up
                delay = 0.0
            self._stop.wait(delay)
