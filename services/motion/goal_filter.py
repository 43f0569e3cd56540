"""Which received motion goals to act on: each goal once, never one older than a stop.

The supervisor sends a goal again (same `goal_id`) until the motion service reports on it,
so a goal lost on the bus is not the end of the episode (`SupervisorConfig.goal_repeat_s`).
That makes copies, and copies (or any goal) can arrive late: delayed on the bus, queued
behind a stalled process. Acting on a late goal would move the arm to where the handover no
longer wants it, or restart a goal that a stop ended. By the sender's stamp (`stamp_ns`,
one clock per source), a goal is ignored when:

- a stop from the same source was stamped at or after it (it was sent before that stop);
- a newer goal from the same source was already accepted (it is a late copy of an older goal);
- it is a copy of the goal being executed: same `goal_id` and source, stamped within
  `DUPLICATE_WINDOW_S` of the first copy accepted (a restarted supervisor that reuses an id
  comes seconds later and is a new goal).

Unstamped messages (``stamp_ns == 0``, hand-made in tests) are always acted on.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Copies of the current goal stamped within this of its first accepted copy are duplicates, s.
DUPLICATE_WINDOW_S = 2.0


@dataclass(frozen=True)
class _Accepted:
    source: str
    goal_id: str
    stamp_ns: int


class GoalFilter:
    """Remembers, per source, the newest stop and the newest accepted goal (sender stamps)."""

    def __init__(self) -> None:
        self._newest_stop_ns: dict[str, int] = {}
        self._newest_goal_ns: dict[str, int] = {}
        self._current: _Accepted | None = None
        self.ignored = 0

    def stop_seen(self, source: str, stamp_ns: int) -> None:
        """A stop from `source` stamped `stamp_ns` arrived (applied or not)."""
        if stamp_ns > 0:
            self._newest_stop_ns[source] = max(stamp_ns, self._newest_stop_ns.get(source, 0))

    def reason_to_ignore(self, source: str, goal_id: str, stamp_ns: int) -> str | None:
        """Why a goal must not be acted on (None: act on it, and it becomes the current one)."""
        if stamp_ns > 0:
            reason = None
            if stamp_ns <= self._newest_stop_ns.get(source, 0):
                reason = "sent before a stop"
            elif stamp_ns <= self._newest_goal_ns.get(source, 0):
                reason = "older than a goal already accepted"
            elif (self._current is not None and self._current.source == source
                  and self._current.goal_id == goal_id
                  and stamp_ns - self._current.stamp_ns < DUPLICATE_WINDOW_S * 1e9):
                reason = "a copy of the goal in progress"
            if reason is not None:
                self.ignored += 1
                return reason
            self._newest_goal_ns[source] = stamp_ns
            self._current = _Accepted(source, goal_id, stamp_ns)
        return None
