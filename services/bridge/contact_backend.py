"""Sim backend with the contact plant: the arm, plus gripper, object, receiver and sensors.

Each bridge tick (10 ms at 100 Hz) advances `robot_sim.contact.plant.ContactPlant` by whole
1 ms plant steps with the latest `gripper/command` force, then publishes

- `sensors/wrist_wrench`: F/T in the transfer loop's gripper frame (x toward the receiver,
  y down), with the plant's noise and bias;
- `sensors/object_motion`: the optical sensor's counts and the slip velocity and a_y
  estimates;
- `sim/truth`: object, receiver hand and tool in the scene's `base` frame, who holds the object,
  whether it was dropped.

Frames: the plant lives in the gripper frame with its origin at the grasp point; a plant point
(x, y) is the base point tool + (x, 0, −y) (x along base +x toward the receiver, y down).
The arm's motion does not feed back into the plant (no inertial coupling): the transfer phase
happens with the arm at rest at the transfer point.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from handover_model import robots
from handover_model.robots import arm_model
from robot_sim.contact.config import ContactSimError, ObjectParams, SimConfig
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import behaviour_by_name
from services.bridge.backend import INT16_MAX, PublishFn, SimBackend, clip_finite
from services.bridge.errors import BridgeConfigError


class ContactSimBackend(SimBackend):
    """Simulated arm + contact plant (see module docstring).

    Args:
        behaviour: receiver behaviour (taking, dropping, bumping, hesitating, absent).
        pull_angle_deg: pull direction φ (deg, > 0 pulls downward).
        object_mass_kg, mu_static, mu_kinetic: the object and its friction with the pads.
        initial_grip_force_n: grip force before any gripper command arrives, N.
        seed: the plant's noise seed (same seed, same commands → same run).
        receiver: extra parameters for the behaviour (e.g. ``reach_start_s``), passed to
            `robot_sim.contact.receiver.behaviour_by_name`.
    """

    name = "sim"

    def __init__(self, *, time_constant_s: float = 0.05, initial_position_rad: np.ndarray | None = None,
                 robot_command_timeout_s: float = 0.2,
                 behaviour: str = "taking", pull_angle_deg: float = 0.0, object_mass_kg: float = 0.2,
                 mu_static: float = 0.6, mu_kinetic: float = 0.5, initial_grip_force_n: float = 10.0,
                 seed: int = 0, receiver: dict[str, Any] | None = None) -> None:
        super().__init__(time_constant_s, initial_position_rad, robot_command_timeout_s)
        try:
            obj = ObjectParams(mass_kg=object_mass_kg, mu_static=mu_static, mu_kinetic=mu_kinetic)
            g = robots.active().gripper  # the arm's gripper: its rates and force range
            config = SimConfig(obj=obj).with_gripper(g.force_rate_n_s, g.loop_rate_hz, g.force_max_n, g.force_min_n)
            kwargs: dict[str, Any] = {"weight_n": object_mass_kg * 9.81, **(receiver or {})}
            if behaviour != "absent":  # no receiver, no pull direction
                kwargs["pull_angle_rad"] = math.radians(pull_angle_deg)
            params = behaviour_by_name(behaviour, **kwargs)
            self.plant = ContactPlant(config, params, seed=seed, initial_grip_force_n=initial_grip_force_n)
        except TypeError as exc:
            raise BridgeConfigError(f"invalid [services.bridge.config.contact.receiver]: {exc}") from None
        except (ContactSimError, ValueError) as exc:  # the plant's own validation says what is wrong
            raise BridgeConfigError(f"invalid [services.bridge.config.contact]: {exc}") from None
        self.behaviour = behaviour
        self.grip_command_n = float(initial_grip_force_n)
        self._obs = None
        self._last_tool = None
        self._tool_speed = 0.0

    def gripper_command(self, grip_force_n: float) -> None:
        self.grip_command_n = float(grip_force_n)

    def step(self, dt_s: float) -> None:
        super().step(dt_s)
        # Whole 1 ms plant steps, the fraction carried over: a late tick advances by more and a
        # short extra tick (a stop wakes the loop) by less, so plant time follows real time.
        self._obs = self.plant.advance_real_time(dt_s, self.grip_command_n)
        tool = arm_model().tool_pose(self.arm.state.position_rad)[0]
        if self._last_tool is not None and dt_s > 0:
            self._tool_speed = float(np.linalg.norm(tool - self._last_tool) / dt_s)
        self._last_tool = tool

    def publish_extras(self, publish: PublishFn) -> None:
        obs = self._obs
        if obs is None or self._last_tool is None:
            return
        tool = self._last_tool
        publish("sensors/wrist_wrench", {
            "force_n": (clip_finite(obs.wrist_force_x_n, 1e4), clip_finite(obs.wrist_force_y_n, 1e4), 0.0),
        })
        publish("sensors/object_motion", {
            "displacement_counts": (int(clip_finite(obs.optical_counts_x, INT16_MAX)),
                                    int(clip_finite(obs.optical_counts_y, INT16_MAX))),
            "counts_per_m": float(obs.optical_counts_per_m),
            "dt_s": float(min(max(obs.optical_dt_s, 1e-6), 1.0)),
            "surface_valid": bool(obs.optical_valid),
            "velocity_m_s": (clip_finite(obs.slip_velocity_x_m_s, 1e3), clip_finite(obs.slip_velocity_y_m_s, 1e3)),
            "accel_y_m_s2": clip_finite(obs.accel_y_m_s2, 1e4),
        })
        in_pads = not bool(obs.left_pads) and float(obs.grip_force_n) > 0.0
        receiver = bool(obs.receiver_holds)
        held_by = "both" if in_pads and receiver else "gripper" if in_pads else "receiver" if receiver else "none"
        obj = tool + np.array([float(obs.object_position_x_m), 0.0, -float(obs.object_position_y_m)])
        hand = tool + np.array([float(obs.hand_position_x_m), 0.0, -float(obs.hand_position_y_m)])
        publish("sim/truth", {
            "object_position_m": tuple(np.clip(obj, -100, 100).tolist()),
            "object_velocity_m_s": (clip_finite(obs.object_velocity_x_m_s, 1e3), 0.0,
                                    clip_finite(-obs.object_velocity_y_m_s, 1e3)),
            "held_by": held_by,
            "dropped": bool(obs.dropped),
            "slip_m": clip_finite(obs.object_position_y_m, 10.0),
            "grip_force_n": max(0.0, clip_finite(obs.grip_force_n, 1e4)),
            "receiver_hand_position_m": tuple(np.clip(hand, -100, 100).tolist()),
            "receiver_pull_n": clip_finite(obs.pull_force_x_n, 1e4),
            "tool_position_m": tuple(tool.tolist()),
            "tool_speed_m_s": min(self._tool_speed, 1000.0),
        })
