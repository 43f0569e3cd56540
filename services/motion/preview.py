"""Plan a motion without the bus: run `MotionController` against an ideal arm at 100 Hz.

The ideal arm reports exactly the planned joints as its measured joints (no lag), so the
record is the planned trajectory; the service streams it to the bridge plus the servo-lag lead
(`MotionConfig.servo_lag_s`). Used by the CLI's one-shot
`plan` mode, the figures and the tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bus_schema.messages import MotionGoal, MotionStop
from services.motion.core import MotionController


@dataclass
class PreviewRecord:
    """A previewed motion.

    Attributes:
        time_s: tick times (N,), s from the goal.
        q_rad: commanded joints (N, n), rad.
        dq_rad_s: commanded joint velocities (N, n), rad/s.
        tool_m: commanded tool positions (N, 3), `base` frame, m.
        state: status state per tick.
        final_status: status after the last tick.
        planned_duration_s: planned duration of the goal, s.
    """

    time_s: np.ndarray
    q_rad: np.ndarray
    dq_rad_s: np.ndarray
    tool_m: np.ndarray
    state: list[str] = field(default_factory=list)
    final_status: object = None
    planned_duration_s: float = 0.0

    @property
    def tool_speed_m_s(self) -> np.ndarray:
        """Tool speed per tick (finite differences), m/s."""
        if len(self.time_s) < 2:
            return np.zeros(len(self.time_s))
        v = np.gradient(self.tool_m, self.time_s, axis=0)
        return np.linalg.norm(v, axis=1)


def preview(
    controller: MotionController,
    goal: MotionGoal,
    q_start_rad: np.ndarray,
    max_time_s: float = 20.0,
    stop_at_s: float | None = None,
    stop: MotionStop | None = None,
) -> PreviewRecord:
    """Run `goal` from `q_start_rad` until it ends (reached/failed/stopped and at rest).

    Args:
        controller: a controller (its state is advanced; use a fresh one per preview).
        goal: the goal to run.
        q_start_rad: measured joints at the start (n,), rad.
        max_time_s: give up after this long.
        stop_at_s, stop: optionally send `stop` at this time after the goal.
    """
    period = controller.config.period_s
    measured = np.asarray(q_start_rad, dtype=float)
    times, qs, dqs, tools, states = [], [], [], [], []
    k = 0
    rest_ticks = 0
    stop_sent = False
    while k * period <= max_time_s:
        t = k * period
        goals = [goal] if k == 0 else []
        stops = []
        if stop is not None and stop_at_s is not None and not stop_sent and t >= stop_at_s:
            stops = [stop]
            stop_sent = True
        out = controller.step(t, measured, goals, stops)
        if out.planned_q_rad is not None:
            measured = out.planned_q_rad
            times.append(t)
            qs.append(out.planned_q_rad)
            dqs.append(out.command_dq_rad_s)
            tools.append(controller.ik.tool_pose(out.planned_q_rad)[0])
            states.append(out.status.state)
        k += 1
        at_rest = out.command_dq_rad_s is None or not np.any(np.abs(out.command_dq_rad_s) > 1e-9)
        if out.status.state != "moving" and at_rest and (stop is None or stop_sent):
            rest_ticks += 1
            if rest_ticks > 2:
                break
    return PreviewRecord(
        time_s=np.array(times),
        q_rad=np.array(qs, dtype=float).reshape(len(qs), len(q_start_rad)),
        dq_rad_s=np.array(dqs, dtype=float).reshape(len(dqs), len(q_start_rad)),
        tool_m=np.array(tools).reshape(-1, 3),
        state=states,
        final_status=controller.status,
        planned_duration_s=controller.planned_duration_s,
    )
