"""Sim backend of a full handover: the arm plus `robot_sim.handover_scene.HandoverScene`.

Each bridge tick (10 ms at 100 Hz) steps the arm, then the scene with the tool position
(pinocchio FK of the arm, computed again only when a joint moved), the tool speed and the
latest `gripper/command` force, and publishes

- `sensors/wrist_wrench`, `sensors/object_motion`: what the sensors of a real gripper would
  read (zero load and no surface while nothing is held);
- `sim/truth`: object, receiver hand and tool in the scene's `base` frame, who holds the object,
  whether it was dropped.

The scene's receiver also drives the simulated Kinect's body (the `kinect` service reads
`receiver_hand_position_m` and `object_position_m` of `sim/truth`; the fake Baxter's own
Kinect thread uses `scene_snapshot`), so the skeleton the tracker sees and the hand that
takes the object are the same hand. A new
supervisor episode (`new_episode`) puts the object back on the table and the receiver's
hand back at rest: the lab assistant resetting the scene.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from handover_model.robots import arm_model
from robot_sim.contact.config import ContactSimError
from robot_sim.handover_scene import HandoverScene, SceneOutput, SceneParams
from services.bridge.backend import INT16_MAX, PublishFn, SimBackend, clip_finite
from services.bridge.errors import BridgeConfigError


def _vec(v: np.ndarray, bound: float = 100.0) -> tuple[float, float, float]:
    """The three components of `v` clipped to [−bound, bound]; NaN or inf become 0 (plain
    floats: three values are cheaper in Python than through numpy's clip and nan_to_num)."""
    x, y, z = v.tolist()
    return clip_finite(x, bound), clip_finite(y, bound), clip_finite(z, bound)


class HandoverSimBackend(SimBackend):
    """Simulated arm + the whole handover scene (see the module docstring).

    Args:
        time_constant_s, initial_position_rad: the arm servo (see `SimBackend`).
        scene_params: the scene (receiver behaviour and body, object, friction, seed).
    """

    name = "sim"

    def __init__(self, scene_params: SceneParams, *, time_constant_s: float = 0.05,
                 initial_position_rad: np.ndarray | None = None,
                 robot_command_timeout_s: float = 0.2) -> None:
        super().__init__(time_constant_s, initial_position_rad, robot_command_timeout_s)
        try:
            self.scene = HandoverScene(scene_params)
        except ContactSimError as exc:
            raise BridgeConfigError(f"invalid [services.bridge.config.contact]: {exc}") from None
        self.grip_command_n = 0.0
        self._out: SceneOutput | None = None
        q = self.arm.state.position_rad
        self._tool = arm_model().tool_pose(q)[0]
        self._tool_q = q.tobytes()  # the joint positions `_tool` is the FK of
        self._tool_speed = 0.0
        self._lock = threading.Lock()
        self._reset_pending = False

    def gripper_command(self, grip_force_n: float) -> None:
        self.grip_command_n = float(grip_force_n)

    def new_episode(self) -> None:
        """Reset the scene (object back on the table) at the next step."""
        self._reset_pending = True

    def episode_running(self, running: bool) -> None:
        """Outside an episode the scene's contact physics may sleep once still (nobody judges
        it then; `robot_sim.contact.rest`): the receiver holding the object after a handover
        is not stepped at 1 kHz for ever."""
        with self._lock:
            self.scene.may_sleep = not running

    def step(self, dt_s: float) -> None:
        super().step(dt_s)
        q = self.arm.state.position_rad
        q_bytes = q.tobytes()
        if q_bytes != self._tool_q:
            tool = arm_model().tool_pose(q)[0]
            if dt_s > 0:
                d = tool - self._tool
                self._tool_speed = math.sqrt(d.dot(d)) / dt_s  # np.linalg.norm's own sqrt(x·x)
            self._tool, self._tool_q = tool, q_bytes
        elif dt_s > 0:
            self._tool_speed = 0.0  # the same joints, the same tool position (FK is deterministic)
        with self._lock:
            if self._reset_pending:
                self.scene.reset()
                self._reset_pending = False
            self._out = self.scene.step(dt_s, self._tool, self._tool_speed, self.grip_command_n)

    def scene_snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        """(receiver's right hand, object centre), `base`, m: for the simulated Kinect."""
        with self._lock:
            return self.scene.hand_m.copy(), self.scene.object_m.copy()

    def publish_extras(self, publish: PublishFn) -> None:
        out = self._out
        if out is None:
            return
        publish("sensors/wrist_wrench", {
            "force_n": (clip_finite(out.wrist_force_n[0], 1e4), clip_finite(out.wrist_force_n[1], 1e4), 0.0),
        })
        publish("sensors/object_motion", {
            "displacement_counts": (int(clip_finite(out.optical_counts[0], INT16_MAX)),
                                    int(clip_finite(out.optical_counts[1], INT16_MAX))),
            "counts_per_m": float(out.optical_counts_per_m),
            "dt_s": float(min(max(out.optical_dt_s, 1e-6), 1.0)),
            "surface_valid": bool(out.optical_valid),
            "velocity_m_s": (clip_finite(out.slip_velocity_m_s[0], 1e3), clip_finite(out.slip_velocity_m_s[1], 1e3)),
            "accel_y_m_s2": clip_finite(out.accel_y_m_s2, 1e4),
        })
        publish("sim/truth", {
            "object_position_m": _vec(out.object_position_m),
            "object_velocity_m_s": _vec(out.object_velocity_m_s, 1e3),
            "held_by": out.held_by,
            "dropped": bool(out.dropped),
            "slip_m": clip_finite(out.slip_m, 10.0),
            "grip_force_n": max(0.0, clip_finite(out.grip_force_n, 1e4)),
            "receiver_hand_position_m": _vec(out.receiver_hand_m),
            "receiver_pull_n": clip_finite(out.receiver_pull_n, 1e4),
            "tool_position_m": _vec(self._tool),
            "tool_speed_m_s": min(self._tool_speed, 1000.0),
        })
