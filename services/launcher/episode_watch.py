"""The handover job's reading of the episodes: bus messages in, progress lines and episode
reports out (no I/O; `services.launcher.handover_job` feeds it from the bus).

An episode is ok when it ended safely (released to the receiver, or a safe ``timeout`` or
``aborted``: the robot kept the object) and, by the simulation's truth, the object was never
dropped nor released into anything but the receiver's hand.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bus_schema.messages import EpisodeSummary, SimTruth, SupervisorState

SAFE_OUTCOMES = ("released", "timeout", "aborted")
#: The one service whose episode summaries the job takes.
SUPERVISOR = "supervisor"


@dataclass
class EpisodeReport:
    """One finished episode as the job saw it."""

    summary: EpisodeSummary
    dropped: bool
    final_holder: str | None
    lines: list[str]

    @property
    def ok(self) -> bool:
        """Safe, never dropped, and (in simulation) released only into the receiver's hand."""
        released_elsewhere = (self.summary.outcome == "released" and self.final_holder is not None
                              and self.final_holder != "receiver")
        return self.summary.outcome in SAFE_OUTCOMES and not self.dropped and not released_elsewhere


@dataclass
class EpisodeWatch:
    """Turns bus messages into progress lines and episode reports (no I/O)."""

    reports: list[EpisodeReport] = field(default_factory=list)
    _phase: tuple[int, str, str] | None = None
    _dropped: dict[int, bool] = field(default_factory=dict)
    _holder: str | None = None
    _episode: int = 0

    def state(self, msg: SupervisorState) -> str | None:
        """A line when the phase (or its reason) changed, else None."""
        key = (msg.episode_id, msg.phase, msg.reason)
        if key == self._phase:
            return None
        self._phase = key
        self._episode = msg.episode_id
        return f"episode {msg.episode_id}: {msg.phase}" + (f" ({msg.reason})" if msg.reason else "")

    def truth(self, msg: SimTruth) -> None:
        self._holder = msg.held_by
        if msg.dropped:
            self._dropped[self._episode] = True

    def accepts(self, msg: EpisodeSummary) -> bool:
        """Only the supervisor's summary counts, and only its first of each episode: a copy,
        or a summary from anyone else, cannot end the run or change its verdict."""
        return msg.source == SUPERVISOR and all(r.summary.episode_id != msg.episode_id for r in self.reports)

    def summary(self, msg: EpisodeSummary) -> EpisodeReport:
        dropped = self._dropped.get(msg.episode_id, False)
        lines = [f"episode {msg.episode_id}: {msg.outcome.upper()}: {msg.reason}"]
        if msg.transfer_point_base_m is not None:
            x, y, z = msg.transfer_point_base_m
            lines.append(f"  transfer point (base frame): x {x:+.3f}  y {y:+.3f}  z {z:+.3f} m "
                         f"({msg.receiver_posture} receiver)")
        if self._holder is not None:
            where = {"receiver": "in the receiver's hand", "gripper": "in the gripper", "both": "held by both",
                     "table": "on the table", "none": "held by nobody"}.get(self._holder, self._holder)
            fate = "DROPPED during the episode" if dropped else "never dropped"
            lines.append(f"  object (sim truth): {where}; {fate}")
        rest = f"; release → arm at rest {msg.release_to_stop_s * 1000:.0f} ms" if msg.outcome == "released" else ""
        lines.append(f"  grip: peak {msg.peak_grip_force_n:.1f} N, overshoot {msg.force_overshoot_n:.1f} N{rest}")
        if msg.phase_durations_s:
            lines.append("  phases: " + ", ".join(f"{k} {v:.2f} s" for k, v in msg.phase_durations_s.items()))
        if msg.replans:
            lines.append(f"  re-plans: {msg.replans}")
        if msg.faults:
            lines.append("  faults: " + "; ".join(msg.faults))
        report = EpisodeReport(msg, dropped, self._holder, lines)
        self.reports.append(report)
        return report
