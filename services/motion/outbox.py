"""Which of a control tick's outputs go on the bus, with which fields.

- `robot/joint_command`: while the arm moves, every tick; while it holds still, on a change,
  else a copy every `HOLD_REPEAT_S` (`services.runtime.repeat`), so the bridge's command
  time-out never fires.
- `motion/status`: on every change of state, goal or reason, else every 1/`status_rate_hz` s.
"""

from __future__ import annotations

from typing import Any

from handover_model import robots
from services.motion.status import TickOutput
from services.runtime.repeat import RepeatGate


class Outbox:
    """Decides, tick by tick, whether the command and the status are published.

    Args:
        status_rate_hz: rate of the status while it does not change, Hz (> 0).

    Attributes:
        command_gate: the repeat gate of the joint commands (its `sent` and `skipped` counters).
    """

    def __init__(self, status_rate_hz: float) -> None:
        self.status_every_s = 1.0 / status_rate_hz
        self.command_gate = RepeatGate()
        self._joint_names = list(robots.active().joints)
        self._last_status_s = -float("inf")

    def command(self, out: TickOutput, now_s: float) -> dict[str, Any] | None:
        """The `JointCommand` fields to publish at `now_s` (monotonic s), or None."""
        if out.command_q_rad is None or out.command_dq_rad_s is None:
            return None
        position = out.command_q_rad.tolist()
        velocity = out.command_dq_rad_s.tolist()
        # Moving: every tick. Holding still: on a change, else a copy every 50 ms.
        if not self.command_gate.due((*position, out.goal_id), now_s, always=any(velocity)):
            return None
        return {"names": self._joint_names, "position_rad": position, "velocity_rad_s": velocity,
                "goal_id": out.goal_id}

    def status(self, out: TickOutput, now_s: float) -> dict[str, Any] | None:
        """The `MotionStatus` fields to publish at `now_s` (monotonic s), or None."""
        if not (out.status_changed or now_s - self._last_status_s >= self.status_every_s):
            return None
        self._last_status_s = now_s
        st = out.status
        return {"goal_id": st.goal_id, "state": st.state, "reason": st.reason, "progress": st.progress,
                "tool_speed_m_s": st.tool_speed_m_s}
