"""The simulated Kinect on a thread of another service's process (the fake Baxter, which
plays the robot and the Kinect driver in one process).

The stand-alone service (`services.sim_kinect.node`) is the normal way to run the simulated
Kinect: a depth frame takes 1.5–3 ms (docs/sim_kinect.md, "Rendering cost"), and on a
thread it competes through the GIL with the host's control loop. The fake Baxter is a test
double whose timing matters less.

Each frame reads the latest arm posture (and, in a handover scene, the receiver's hand and
the object) handed over by the host's loop, renders skeleton and depth with
`robot_sim.kinect.KinectSim`, and publishes `perception/skeleton`, `perception/depth` and
`sim/kinect_truth`.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import numpy as np

from bus_schema import topics
from services.runtime import RateLimitedLog, RateLoop
from services.sim_kinect.config import KinectConfig
from services.sim_kinect.core import TruthGate, make_kinect_sim

log = logging.getLogger(__name__)


class KinectThread:
    """Publishes simulated skeleton, depth and Kinect truth frames until `stop()`.

    Args:
        config: the Kinect (rate, body, seed, scripted reach).
        node: the host's open `ServiceNode` (publishers are declared on it).
    """

    def __init__(self, config: KinectConfig, node: Any) -> None:
        self.sim = make_kinect_sim(config)
        self.rate_hz = config.rate_hz
        self._declare_outputs(node)
        self._truth = node.publisher(topics.KINECT_TRUTH)
        self._truth_gate = TruthGate()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._q_arm: np.ndarray | None = None
        self._hand: np.ndarray | None = None
        self._object: np.ndarray | None = None
        self._errors = RateLimitedLog(log, 5.0)
        self.frames = 0
        self._thread = threading.Thread(target=self._run, name="kinect", daemon=True)

    def _declare_outputs(self, node: Any) -> None:
        """Declare the camera's outputs (a subclass sends them elsewhere: the fake OpenNI)."""
        self._skeleton = node.publisher(topics.SKELETON)
        self._depth = node.publisher(topics.DEPTH)

    def _publish(self, frame: Any) -> None:
        """Send one rendered frame's skeleton and depth (`robot_sim.kinect.KinectFrame`)."""
        self._skeleton.put(**frame.skeleton_fields)
        self._depth.put(**frame.depth_fields)

    def update_arm(self, q_rad: np.ndarray, hand_m: np.ndarray | None = None,
                   object_m: np.ndarray | None = None) -> None:
        """Hand over the arm's latest joint positions (rad) and, when a handover scene drives
        the receiver, its right hand and the object (m, `base`) (called by the host's loop)."""
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
        for _frame in RateLoop(self.rate_hz, self._stop, name=f"kinect thread {self.rate_hz:g} Hz loop"):
            with self._lock:
                q = None if self._q_arm is None else self._q_arm.copy()
                hand, obj = self._hand, self._object
            if q is not None:
                try:
                    frame = self.sim.step(time.monotonic() - t0, q, object_position_m=obj, right_hand_m=hand)
                    self._publish(frame)
                    truth_now = self._truth_gate.due(frame, time.monotonic())
                    if truth_now is not None:
                        self._truth.put(**truth_now)
                    self.frames += 1
                except Exception as exc:  # noqa: BLE001 - a bad frame must not kill the host
                    self._errors.warning("kinect", f"simulated Kinect frame failed: {exc!r}")
