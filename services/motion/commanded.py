"""The commanded joint state: what the service last sent, its derivatives and the tool's speed."""

from __future__ import annotations

import numpy as np

from services.motion.ik import ArmIk

#: The reported tool speed is capped at this, m/s (a finite value on the bus whatever happens).
MAX_REPORTED_TOOL_SPEED_M_S = 1000.0


class CommandedState:
    """The last command and its derivatives, and the commanded tool's velocity.

    Attributes:
        q_rad: commanded joint positions (n,), rad, or None before the first command.
        dq_rad_s: commanded joint velocities (n,), rad/s.
        ddq_rad_s2: commanded joint accelerations (n,), rad/s².
        tool_m: commanded tool position (3,), `base` frame, m, or None before the first command.
        tool_velocity_m_s: tool velocity between the last two commands (3,), m/s.
        tool_speed_m_s: its norm, m/s (0 once a move has come to rest).
    """

    def __init__(self, ik: ArmIk) -> None:
        self.ik = ik
        self.q_rad: np.ndarray | None = None
        self.dq_rad_s = np.zeros(7)
        self.ddq_rad_s2 = np.zeros(7)
        self.tool_m: np.ndarray | None = None
        self.tool_velocity_m_s = np.zeros(3)
        self.tool_speed_m_s = 0.0

    @property
    def reported_tool_speed_m_s(self) -> float:
        """The tool speed for the status, m/s (capped at `MAX_REPORTED_TOOL_SPEED_M_S`)."""
        return float(min(self.tool_speed_m_s, MAX_REPORTED_TOOL_SPEED_M_S))

    def record(self, q: np.ndarray, dt_s: float, dq: np.ndarray | None = None,
               ddq: np.ndarray | None = None) -> None:
        """Record a new command q (n,), rad, one tick of `dt_s` s after the last, with its
        velocity dq (rad/s) and acceleration ddq (rad/s²); finite differences when not given."""
        previous_q = self.q_rad
        previous_dq = self.dq_rad_s
        if dq is None:
            dq = np.zeros(7) if previous_q is None else (q - previous_q) / dt_s
        if ddq is None:
            ddq = (dq - previous_dq) / dt_s
        self.q_rad = q.copy()
        self.dq_rad_s = np.asarray(dq, dtype=float).copy()
        self.ddq_rad_s2 = np.asarray(ddq, dtype=float).copy()
        p, _ = self.ik.tool_pose(q)
        if self.tool_m is not None:
            self.tool_velocity_m_s = (p - self.tool_m) / dt_s
            self.tool_speed_m_s = float(np.linalg.norm(self.tool_velocity_m_s))
        self.tool_m = p

    def zero_derivatives(self) -> None:
        """The commanded position is final: zero velocity and acceleration."""
        self.dq_rad_s[:] = 0.0
        self.ddq_rad_s2[:] = 0.0

    def hold_at(self, q: np.ndarray) -> None:
        """Command `q` (n,), rad, at rest from now on (no tool-speed update)."""
        self.q_rad = q.copy()
        self.zero_derivatives()

    def is_moving(self) -> bool:
        """Some commanded joint velocity is not zero."""
        return bool(np.any(np.abs(self.dq_rad_s) > 1e-9))

    def sent_q_rad(self, servo_lag_s: float) -> np.ndarray | None:
        """The joints to send (n,), rad: the command plus the servo-lag lead
        `servo_lag_s × velocity` (s × rad/s), clipped to the joint limits; None before the
        first command."""
        if self.q_rad is None:
            return None
        lead = servo_lag_s * self.dq_rad_s
        return np.clip(self.q_rad + lead, self.ik.lower_rad, self.ik.upper_rad)
