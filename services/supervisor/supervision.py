"""What the supervisor's loop does at each wake-up, without the bus (pure, no I/O, no clock):
it feeds the sequencer's snapshot and the health watch with what was received, starts the
first episode once every watched service is alive, runs the sequencer's tick and says when
`supervisor/state` is due and how long the next tick waits. `node.run_supervisor` only moves
messages in and out.

Times are the local monotonic clock (s).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from services.supervisor.config import SupervisorConfig
from services.supervisor.core import Sequencer
from services.supervisor.health import HealthWatch, Stall
from services.supervisor.targets import TargetFilter
from services.supervisor.tick_io import Actions, Snapshot

#: supervisor/state is published at least this often, s.
STATE_PERIOD_S = 0.05
#: Tick period once the last episode has ended (`Sequencer.resting`), s: nothing but the
#: watchdog can act then. Half the state period, so the state still goes out every 50 ms;
#: a release or a liveliness change wakes the loop at once whatever the period, and a
#: killed or stopped service is still seen within 100 ms (DESIGN §8).
RESTING_PERIOD_S = STATE_PERIOD_S / 2
#: A tick this close before the state is due sends it (a tick a hair early would otherwise
#: push the state one whole tick late), s.
STATE_EARLY_S = 0.004
#: Longest text of `supervisor/state`'s reason, characters; longest elapsed time, s.
STATE_REASON_CHARS = 512
STATE_ELAPSED_MAX_S = 86400.0


class Supervision:
    """The sequencer, its snapshot and the health watch, between two bus wake-ups.

    Args:
        config: supervisor settings.
        health: the watch of the other services.
        home_rad: the arm's home posture for the retract (7 joints, rad).
        now_s: when the loop starts (the node is ready), s.
    """

    def __init__(self, config: SupervisorConfig, health: HealthWatch, home_rad: Sequence[float],
                 now_s: float) -> None:
        self.config = config
        self.health = health
        self.sequencer = Sequencer(config, home_rad)
        self.snapshot = Snapshot(now_s=now_s)
        self.targets = TargetFilter()
        self.started_s = now_s
        self.ready_since_s: float | None = None
        self.last_wake_s = now_s
        self.last_state_s = -1.0

    # ------------------------------------------------------------------ inputs
    def take(self, name: str, suffix: str, msg: Any, rx_s: float) -> None:
        """A message of input `name` (a `Snapshot` field) on topic `suffix`, received at
        `rx_s` (s): into the snapshot (a target into the median filter) and the watch."""
        setattr(self.snapshot, name, msg)
        if hasattr(self.snapshot, f"{name}_rx_s"):
            setattr(self.snapshot, f"{name}_rx_s", rx_s)
        if name == "target":
            self.targets.offer(msg, rx_s)
        self.health.stream(suffix, rx_s)

    def woke(self, now_s: float) -> Stall | None:
        """The loop woke at `now_s` (s): whether it came late (`HealthWatch.stall`)."""
        late_s, self.last_wake_s = now_s - self.last_wake_s, now_s
        return self.health.stall(late_s, now_s)

    # ------------------------------------------------------------------ the tick
    def period_s(self) -> float:
        """The tick period in force, s: slower once resting (`RESTING_PERIOD_S`)."""
        if self.sequencer.resting:
            return max(RESTING_PERIOD_S, self.config.period_s)
        return self.config.period_s

    def start(self, now_s: float) -> tuple[Actions | None, list[str]]:
        """Before the first episode: its start once every watched service has been alive for
        `start_delay_s`, else None; and the services still missing once `start_timeout_s`
        has passed (the state's reason names them), else an empty list."""
        seq, watchdog = self.sequencer, self.health.watchdog
        if seq.phase != "idle" or seq.episode is not None:
            return None, []
        if watchdog.all_alive():
            self.ready_since_s = self.ready_since_s or now_s
            if now_s - self.ready_since_s >= self.config.start_delay_s:
                return seq.start_episode(now_s), []
        elif now_s - self.started_s > self.config.start_timeout_s:
            seq.reason = f"services not alive: {', '.join(watchdog.missing())}"
            return None, watchdog.missing()
        return None, []

    def tick(self, now_s: float) -> Actions:
        """The sequencer's tick at `now_s` (s), with the steadied transfer target."""
        self.snapshot.now_s = now_s
        self.snapshot.target = self.targets.current(now_s)
        return self.sequencer.tick(self.snapshot)

    def state_due(self, actions: Actions, now_s: float) -> dict[str, Any] | None:
        """The `supervisor/state` fields to publish after `actions` at `now_s` (s): on a
        change, and at least every `STATE_PERIOD_S`; None when not due."""
        if not actions.state_changed and now_s - self.last_state_s < STATE_PERIOD_S - STATE_EARLY_S:
            return None
        seq = self.sequencer
        self.last_state_s = now_s
        return {"phase": seq.phase, "episode_id": seq.episode_id, "reason": seq.reason[:STATE_REASON_CHARS],
                "elapsed_s": min(seq.elapsed_s(now_s), STATE_ELAPSED_MAX_S), "grip_request": seq.grip_request}
