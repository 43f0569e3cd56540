"""The bridge's own protective stop when the supervisor dies in the middle of an episode.

The supervisor sequences the handover and sends every protective stop; when it dies (killed,
crashed), only the launcher used to notice, from its child's exit, and only during one of its
bus jobs. That was one Python thread of one process: beside a heavy load (the Rerun viewer
replaying a run with software rendering) it once sent its stop 175 ms after the kill. The bridge
now watches the supervisor's liveliness token too, a second path through another process: when
the token goes while an episode runs (the supervisor's newest phase is not a resting one), the
bridge brakes at once, latches the stop as protective for the episode, and says so on
``motion/stop`` (source ``bridge``): motion ends its goal, and the stop is in the recording.

A supervisor that ends normally (its last episode over: ``done``) or between episodes
(``idle``, ``failed``, ``protective_stop``: `PHASES_OUTSIDE_EPISODE`) leaves without a stop; a
token that goes before any supervisor state was seen stops nothing either (no episode of it
ran here). A frozen supervisor keeps its token: the launcher's watch of its state catches that.

Order: the loop takes the token changes queued so far (`take_tokens`) *before* it drains the
supervisor's states, and judges them after (`due`): a state and a token's end that both arrive
while the loop drains are judged at the next tick, after that state. Zenoh does not promise
that a supervisor's last state reaches the bridge before its token's end (a declaration may
overtake a queued state); the supervisor sends its last state (``done``) before its summary,
and the launcher stops it only after the summary, so at a normal end the state has long
arrived. Should the order ever be lost, the cost is a stop of an arm already at rest.

Pure logic: the liveliness callback (a Zenoh thread) calls `token`; the bridge's loop calls
`take_tokens`, then `state` for each supervisor state, then `due`, once per tick.
"""

from __future__ import annotations

import collections

from bus_schema.messages import PHASES_OUTSIDE_EPISODE


class SupervisorLoss:
    """Whether the supervisor's liveliness token went while one of its episodes ran."""

    def __init__(self) -> None:
        #: The supervisor's newest phase (None until a state arrived).
        self.phase: str | None = None
        #: The episode of that state.
        self.episode_id: int | None = None
        #: How many stops this watch asked for.
        self.stops = 0
        # Token changes from the liveliness callback: deque appends and pops are thread-safe.
        self._tokens: collections.deque[bool] = collections.deque()

    def token(self, alive: bool) -> None:
        """The supervisor's liveliness token appeared (`alive`) or went (any thread)."""
        self._tokens.append(alive)

    def pending(self) -> bool:
        """A token change waits for `due` (the loop's urgent check: cheap, any thread)."""
        return bool(self._tokens)

    def state(self, phase: str, episode_id: int) -> None:
        """A supervisor state: its phase and episode."""
        self.phase, self.episode_id = phase, episode_id

    def take_tokens(self) -> list[bool]:
        """The token changes queued so far, oldest first (the loop, before the tick's states)."""
        tokens = []
        while self._tokens:
            tokens.append(self._tokens.popleft())
        return tokens

    def due(self, tokens: list[bool]) -> str | None:
        """The reason of a protective stop when one of `tokens` (from `take_tokens`, before this
        tick's states) is the token's end while an episode ran (once per loss), else None."""
        reason = None
        for alive in tokens:
            if alive or self.phase is None or self.phase in PHASES_OUTSIDE_EPISODE:
                continue
            reason = (f"supervisor lost: its liveliness token went during {self.phase} "
                      f"(episode {self.episode_id})")
            self.phase = None  # a dead supervisor's episode runs no more: one stop per loss
        if reason is not None:
            self.stops += 1
        return reason
