"""What the motion controller reports: the status (`MotionStatus` on the bus), when it changed,
and each tick's output (`TickOutput`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

#: Longest reason kept in a status, characters.
MAX_REASON_CHARS = 512


@dataclass(frozen=True)
class Status:
    """What the service reports (fields of `MotionStatus`).

    Attributes:
        state: ``idle``, ``moving``, ``reached``, ``stopped`` or ``failed``.
        goal_id: the goal the state is about.
        reason: why (a stop's or a failure's reason), at most `MAX_REASON_CHARS`.
        progress: fraction of the planned motion done, in [0, 1].
        tool_speed_m_s: commanded tool speed, m/s.
    """

    state: str
    goal_id: str = ""
    reason: str = ""
    progress: float = 0.0
    tool_speed_m_s: float = 0.0


class StatusBoard:
    """The current `Status` and whether its state, goal or reason changed during this tick.

    Attributes:
        status: the current status.
        changed: the state, goal or reason changed since `begin_tick`.
    """

    def __init__(self) -> None:
        self.status = Status("idle")
        self.changed = False

    def begin_tick(self) -> None:
        """A new tick starts: nothing has changed yet."""
        self.changed = False

    def set(self, state: str, goal_id: str, tool_speed_m_s: float, reason: str = "",
            progress: float | None = None) -> bool:
        """Set the status (`progress` None keeps the current one; it is clipped to [0, 1]).

        Returns:
            True when the state, goal or reason changed (a line worth logging).
        """
        old = self.status
        progress = old.progress if progress is None else progress
        self.status = Status(
            state=state,
            goal_id=goal_id,
            reason=reason[:MAX_REASON_CHARS],
            progress=float(min(1.0, max(0.0, progress))),
            tool_speed_m_s=tool_speed_m_s,
        )
        if (old.state, old.goal_id, old.reason) == (state, goal_id, self.status.reason):
            return False
        self.changed = True
        return True

    def set_tool_speed(self, tool_speed_m_s: float) -> None:
        """Report a new tool speed, m/s (not a change worth a status message of its own)."""
        if self.status.tool_speed_m_s != tool_speed_m_s:
            self.status = replace(self.status, tool_speed_m_s=tool_speed_m_s)


@dataclass(frozen=True)
class TickOutput:
    """Result of one control tick.

    Attributes:
        command_q_rad: joint positions to send (n,), rad, or None to send nothing: the planned
            joints plus the servo-lag lead `servo_lag_s × planned velocity` (clipped to limits).
        planned_q_rad: the planned joint positions (where the arm should be now), rad.
        command_dq_rad_s: feed-forward joint velocities (n,), rad/s (None with no command).
        goal_id: goal the command belongs to.
        status: current status.
        status_changed: the state, goal or reason changed during this tick.
    """

    command_q_rad: np.ndarray | None
    planned_q_rad: np.ndarray | None
    command_dq_rad_s: np.ndarray | None
    goal_id: str
    status: Status
    status_changed: bool
