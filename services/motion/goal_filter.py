"""Which received motion goals to act on: each goal once, never one older than a stop.

The supervisor sends a goal again (same `goal_id`) until the motion service reports on it,
so a goal lost on the bus is not the end of the episode (`SupervisorConfig.goal_repeat_s`).
That makes copies, and copies (or any goal) can arrive late: delayed on the bus, queued
behind a stalled process. Acting on a late goal would move the arm to where the handover no
longer wants it, or restart a goal that a stop ended. Per source, a goal is ignored when it is:

- a copy of the goal in progress (same `goal_id`), however late;
- older, by the sender's stamp, than a goal already accepted (a late copy of an earlier goal);
- older, by the sender's stamp, than a stop from the same source (sent before that stop).

Stamps (`stamp_ns`, the sender's wall clock) are only compared between two messages of one
source, never across hosts. A sender that restarted (its per-publisher `seq` went back) starts
afresh, so a new supervisor may reuse goal ids. A backward step of the sender's clock would
make its next goals look old and be ignored until the clock catches up (fail-safe: the episode
times out); keep NTP slewing, not stepping, on a running robot. Unstamped messages
(``stamp_ns == 0``, hand-made in tests) are only checked for copies of the goal in progress.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class _Source:
    """What one sender (one process instance) has said so far."""

    newest_stop_ns: int = 0
    newest_goal_ns: int = 0
    last_goal_seq: int = -1
    current_goal_id: str | None = None


class GoalFilter:
    """Remembers, per source, the newest stop and the newest accepted goal (sender stamps)."""

    def __init__(self) -> None:
        self._sources: dict[str, _Source] = {}
        self.ignored = 0

    def _source(self, name: str) -> _Source:
        return self._sources.setdefault(name, _Source())

    def stop_seen(self, source: str, stamp_ns: int) -> None:
        """A stop from `source` stamped `stamp_ns` arrived, applied or not. Call it for a
        tick's stops before its goals: a goal sent before a stop that arrives in the same tick
        is then not planned at all."""
        s = self._source(source)
        if stamp_ns > 0:
            s.newest_stop_ns = max(stamp_ns, s.newest_stop_ns)

    def reason_to_ignore(self, source: str, goal_id: str, seq: int, stamp_ns: int) -> str | None:
        """Why a goal must not be acted on (None: act on it, and it becomes the current one)."""
        s = self._source(source)
        if seq < s.last_goal_seq:  # the sender restarted: its goals (and goal ids) start afresh
            s.newest_goal_ns, s.current_goal_id = 0, None
        s.last_goal_seq = seq
        reason = None
        if goal_id == s.current_goal_id:
            reason = "a copy of the goal in progress"
        elif stamp_ns > 0 and stamp_ns <= s.newest_stop_ns:
            reason = "sent before a stop"
        elif stamp_ns > 0 and stamp_ns <= s.newest_goal_ns:
            reason = "older than a goal already accepted"
        if reason is not None:
            self.ignored += 1
            return reason
        if stamp_ns > 0:
            s.newest_goal_ns = stamp_ns
        s.current_goal_id = goal_id
        return None
