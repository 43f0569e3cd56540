"""One handover episode's record: its goals to the motion service, what was measured, its
outcome and the summary published at its end (pure, no I/O).

Times are the local monotonic clock (s); positions are the scene's `base` frame (m).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bus_schema.messages import MotionStatus

#: Receiver postures a summary names; anything else is reported as ``unknown``.
POSTURES = ("standing", "sitting")


@dataclass
class Episode:
    """What the supervisor keeps of the episode in progress (or the last one)."""

    episode_id: int
    started_s: float
    object_position_m: np.ndarray | None = None
    object_mass_kg: float = 0.0
    goal_id: str = ""
    goal_count: int = 0
    goal_sent_s: float = 0.0
    #: The current goal's fields while the motion service has not reported on it (sent
    #: again every `goal_repeat_s`); None once it has, or after a stop.
    goal_unacknowledged: dict[str, Any] | None = None
    goal_repeated_s: float = 0.0
    goal_repeats: int = 0
    reach_position_m: np.ndarray | None = None
    receiver_posture: str = "unknown"
    replans: int = 0
    step: str = ""
    step_since_s: float = 0.0
    grasp_since_s: float | None = None
    transfer_start_grip_n: float | None = None
    peak_grip_n: float = 0.0
    release_s: float | None = None
    release_to_stop_s: float = 0.0
    at_rest_since_s: float | None = None
    outcome: str = ""
    outcome_reason: str = ""
    faults: list[str] = field(default_factory=list)
    durations_s: dict[str, float] = field(default_factory=dict)
    summary_sent: bool = False

    def add_time(self, phase: str, seconds: float) -> None:
        """Count `seconds` (s) more in `phase`."""
        self.durations_s[phase] = self.durations_s.get(phase, 0.0) + seconds

    # ------------------------------------------------------------------ goals
    def new_goal(self, kind: str, now_s: float, **fields: Any) -> dict[str, Any]:
        """The fields of a new `motion/goal` of `kind` sent at `now_s` (s), with its own
        ``goal_id``; kept to be sent again until the motion service reports on it."""
        self.goal_count += 1
        self.goal_id = f"e{self.episode_id}-{kind}-{self.goal_count}"
        self.goal_sent_s = self.goal_repeated_s = now_s
        goal = {"goal_id": self.goal_id, "kind": kind, **fields}
        self.goal_unacknowledged = dict(goal)
        return goal

    def goal_status(self, motion: MotionStatus | None) -> str | None:
        """The motion state of the current goal (None while the motion service has not
        reported on it yet)."""
        if motion is None or motion.goal_id != self.goal_id:
            return None
        return motion.state

    def goal_to_repeat(self, motion: MotionStatus | None, now_s: float, repeat_s: float) -> dict[str, Any] | None:
        """The current goal again (same ``goal_id``) when `repeat_s` (s) has passed since it
        was last sent and the motion service has not reported on it; None otherwise (and for
        good once it has reported)."""
        if self.goal_unacknowledged is None:
            return None
        if self.goal_status(motion) is not None:
            self.goal_unacknowledged = None
            return None
        if now_s - self.goal_repeated_s < repeat_s:
            return None
        self.goal_repeated_s = now_s
        self.goal_repeats += 1
        return dict(self.goal_unacknowledged)

    # ------------------------------------------------------------------ the end
    def summary(self) -> dict[str, Any]:
        """The `supervisor/episode` fields (without header), bounded to the schema's sizes."""
        overshoot = 0.0
        if self.transfer_start_grip_n is not None:
            overshoot = max(0.0, self.peak_grip_n - self.transfer_start_grip_n)
        return {
            "episode_id": self.episode_id,
            "outcome": self.outcome,
            "reason": self.outcome_reason[:512],
            "transfer_point_base_m": (None if self.reach_position_m is None
                                      else tuple(float(v) for v in self.reach_position_m)),
            "receiver_posture": self.receiver_posture if self.receiver_posture in POSTURES else "unknown",
            "phase_durations_s": {k: min(v, 86400.0) for k, v in list(self.durations_s.items())[:16]},
            "peak_grip_force_n": self.peak_grip_n,
            "force_overshoot_n": overshoot,
            "release_to_stop_s": self.release_to_stop_s,
            "replans": self.replans,
            "faults": [f[:512] for f in self.faults[:32]],
        }
