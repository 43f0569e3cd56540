"""Where the tracker's inputs come from, one class per source, each fed at the node's tick.

- `BusInputs`: `robot/joint_state`, `perception/depth` and `perception/skeleton` from the
  bus (a real Kinect's driver, the ROS 1 path, the stand-alone simulated Kinect service);
- `SimKinectInputs`: the simulated Kinect rendered in the tracker's own process
  (``sensor = "sim"``, the default simulation profile). Each tick renders one frame from the
  newest joint state and `sim/truth`, feeds it to the pipeline directly and publishes the
  skeleton and `sim/kinect_truth` for the recorder (the truth when the body moved, or every
  0.1 s when it is still, `TruthGate`; the depth image too only with
  ``publish_depth``): a 150 kB image 30 times a second no longer crosses the bus to reach its
  only reader, and the stack has one process fewer (issue 16). The pipeline gets the depth
  in metres, made only when it reads them (`robot_sim.kinect.readings`): while the receiver
  stands still, only on the object detection's frames (every third while the supervisor
  locates the object, every 15th otherwise: `core.object_wanted`);
- `ReplayInputs`: a replay file, paced in real time.

Each `feed(feeder, now_s)` hands the tick's inputs to the `services.tracker.node._Feeder`
(duck-typed: ``joint_state``, ``depth``, ``skeleton``) and returns False once the source has
ended (a replay without loop).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from bus_schema import topics as T
from services.runtime.logs import RateLimitedLog
from services.sim_kinect.config import KinectConfig
from services.sim_kinect.core import TruthGate, arm_posture_rad, make_kinect_sim, scene_input
from services.tracker.pointcloud import depth_frame_from_camera
from services.tracker.replay import ReplayItem, read_replay

log = logging.getLogger("tracker")


class BusInputs:
    """Joint state, depth and skeleton read from the bus at the tick (none wakes the loop;
    only the newest depth image and joint state of a tick go in: the pipeline keeps only the
    newest anyway)."""

    def __init__(self, node: Any) -> None:
        self.joint_state = node.subscribe(T.JOINT_STATE, wake=False)
        self.depth = node.subscribe(T.DEPTH, queue_size=4, wake=False)
        self.skeleton = node.subscribe(T.SKELETON, wake=False)

    def feed(self, feeder: Any, now_s: float) -> bool:
        for rx in reversed(self.joint_state.drain()):  # the newest usable one
            if feeder.joint_state(rx.msg, rx.rx_monotonic):
                break
        depths = self.depth.drain()
        if depths:
            feeder.depth(depths[-1].msg, depths[-1].rx_monotonic)
        for rx in self.skeleton.drain():
            feeder.skeleton(rx.msg, rx.rx_monotonic)
        return True


class SimKinectInputs:
    """The simulated Kinect in the tracker's process (see the module docstring).

    Args:
        config: the Kinect (`[services.tracker.config.sim_kinect]`: rate, body, scene, seed).
        node: the tracker's open `ServiceNode`.
        publish_depth: also publish `perception/depth` (for a recorder that records depth).
    """

    def __init__(self, config: KinectConfig, node: Any, publish_depth: bool = False) -> None:
        self.config = config
        self.sim = make_kinect_sim(config)
        self.joint_state = node.subscribe(T.JOINT_STATE, wake=False)
        # Only the handover scene follows the bridge's truth (the receiver's hand, the object).
        self.truth = node.subscribe(T.SIM_TRUTH, queue_size=1, wake=False) if config.scene == "handover" else None
        self._skeleton_pub = node.publisher(T.SKELETON)
        self._truth_pub = node.publisher(T.KINECT_TRUTH)
        self._truth_gate = TruthGate()  # a still body's truth: 10 copies a second, not 30
        self._depth_pub = node.publisher(T.DEPTH) if publish_depth else None
        self._warn = RateLimitedLog(log, 5.0)
        self._t0_s: float | None = None  # the scripted reach's clock starts at the first frame
        self._last_state: Any = None  # the newest usable joint state so far
        self.frames = self.skipped = self.failed = 0

    def feed(self, feeder: Any, now_s: float) -> bool:
        if not self.config.enabled:  # ``enabled = false``: the camera is off, nothing to see
            return True
        state = None
        for rx in reversed(self.joint_state.drain()):  # the newest usable one
            if feeder.joint_state(rx.msg, rx.rx_monotonic):
                state = rx.msg
                break
        if state is None:
            state = self._last_state
            if state is None:
                return True  # nothing to render before the first joint state
        self._last_state = state
        q = arm_posture_rad(state.names, state.position_rad)
        if q is None:
            self.skipped += 1
            self._warn.warning("joints", "joint state without the arm's joints: frame skipped",
                               skipped=self.skipped)
            return True
        truth = self.truth.latest() if self.truth is not None else None
        scene = scene_input(self.config.scene, None if truth is None else truth.msg.receiver_hand_position_m,
                            None if truth is None else truth.msg.object_position_m)
        if self._t0_s is None:
            self._t0_s = now_s
        try:
            frame = self.sim.step(now_s - self._t0_s, q, object_position_m=scene.object_position_m,
                                  right_hand_m=scene.right_hand_m)
        except Exception as exc:  # noqa: BLE001 - a bad frame must not kill the tracker
            self.failed += 1
            self._warn.warning("render", f"simulated Kinect frame failed: {exc!r}", failed=self.failed)
            return True
        skeleton = self._skeleton_pub.put(**frame.skeleton_fields)
        truth_now = self._truth_gate.due(frame, now_s)
        if truth_now is not None:
            self._truth_pub.put(**truth_now)
        if self._depth_pub is not None:
            self._depth_pub.put(**frame.depth_fields)
        self.frames += 1
        # The pipeline reads the depth in metres, and only on the frames it needs them.
        cam = frame.camera_fields
        feeder.depth_frame(depth_frame_from_camera(frame.readings.metres, cam["fx"], cam["fy"], cam["cx"], cam["cy"],
                                                   cam["camera_position_m"], cam["camera_orientation_xyzw"], now_s))
        feeder.skeleton(skeleton, now_s)
        return True


class ReplayInputs:
    """A replay file's messages at their recorded times (s from the file's start), looped or not."""

    def __init__(self, path: Path, loop: bool, start_s: float) -> None:
        self.path, self.loop = path, loop
        self._items = iter(read_replay(path))
        self._pending: ReplayItem | None = None
        self._start_s = start_s
        log.info("replaying %s", path)

    def feed(self, feeder: Any, now_s: float) -> bool:
        while True:
            if self._pending is None:
                self._pending = next(self._items, None)
                if self._pending is None:
                    if not self.loop:
                        log.info("replay finished")
                        return False
                    self._items = iter(read_replay(self.path))
                    self._start_s = now_s
                    continue
            if self._start_s + self._pending.t_s > now_s:
                return True
            item, self._pending = self._pending, None
            if item.topic is T.JOINT_STATE:
                feeder.joint_state(item.msg, now_s)
            elif item.topic is T.DEPTH:
                feeder.depth(item.msg, now_s)
            elif item.topic is T.SKELETON:
                feeder.skeleton(item.msg, now_s)
