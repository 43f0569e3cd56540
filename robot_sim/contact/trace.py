"""`TraceRecorder`: one scalar episode of the contact plant, sample by sample, as an
`EpisodeTrace` (the plant's state in its gripper frame: x toward the receiver, y down; SI units)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robot_sim.contact.outcome import EpisodeTrace

if TYPE_CHECKING:
    from robot_sim.contact.plant import ContactPlant

__all__ = ["TraceRecorder"]


class TraceRecorder:
    """Collects one scalar episode's samples into an `EpisodeTrace`."""

    _FIELDS = ("time_s", "mode", "grip_force_n", "pull_force_x_n", "pull_force_y_n",
               "object_position_x_m", "object_position_y_m", "object_accel_y_m_s2", "receiver_holds",
               "grip_command_n", "object_velocity_x_m_s", "object_velocity_y_m_s", "object_accel_x_m_s2",
               "sensed_force_x_n", "sensed_force_y_n", "accel_estimate_y_m_s2", "optical_valid",
               "hand_position_x_m", "hand_position_y_m", "receiver_grasp")

    def __init__(self):
        self._rows: list[tuple] = []

    def record(self, plant: ContactPlant, grip_command_n: float) -> None:
        """Append the plant's current state (one episode only)."""
        p = plant
        self._rows.append((p.time_s, p.mode, p.grip_force_n, p.pull_x, p.pull_y, p.px, p.py, p.ay, p.holds,
                           grip_command_n, p.vx, p.vy, p.ax, p.ft.force_x_n, p.ft.force_y_n,
                           p.optical.accel_y_m_s2, p.optical.valid, p.hx, p.hy, p.grasp))

    def trace(self, label: str = "") -> EpisodeTrace:
        """The recorded samples as an `EpisodeTrace`."""
        cols = list(zip(*self._rows)) if self._rows else [()] * len(self._FIELDS)
        arrays = {}
        for name, col in zip(self._FIELDS, cols):
            if name == "mode":
                arrays[name] = np.asarray(col, dtype=np.int8)
            elif name in ("receiver_holds", "optical_valid"):
                arrays[name] = np.asarray(col, dtype=bool)
            else:
                arrays[name] = np.asarray(col, dtype=float)
        return EpisodeTrace(**arrays, label=label)
