"""The handover sequence as an explicit state machine (pure logic: no I/O, no clock).

Phases (thesis Fig. 30, DESIGN §6 supervisor), at `rate_hz` (100 Hz):

    idle → locate → pick → plan → reach → transfer → released → retract → done
                              ↑        ↓ receiver lost        ↓ time-out
                              └─ hold ─┘ (then abort)         retract with the object

- **locate**: the tracker sees the receiver (tracked, fresh) and the object on the table.
- **pick**: approach from above (`pregrasp_height_m`), go down, close (`grip_request` carry)
  until the wrist feels the object's weight, lift (`lift_height_m`): jerk-limited joint moves.
- **plan**: take the planner's DJT transfer target.
- **reach**: a straight minimum-jerk reach to the target with the planner's timing, the
  receiver's hand given for the 0.25 m/s speed cap; the gripper runs its fail-safe
  controller (`grip_request` transfer). A target that moves more than `replan_threshold_m`
  gives a new reach (at most `max_replans`). A lost receiver (not tracked for
  `human_lost_s`) stops the arm (**hold**); it re-plans when the receiver is back within
  `human_return_s`, else aborts and retracts with the object.
- **transfer**: the arm holds at the transfer point; the gripper decides the release. A slip
  is the gripper's business (it regrasps); the supervisor holds and waits. No release within
  `transfer_timeout_s`: retract with the object (outcome ``timeout``).
- **release interrupt**: the gripper's release event (or its state saying released, in case
  the event was lost) stops all arm motion at once: a `motion/stop` (the bridge brakes on it
  too), repeated until the motion service reports stopped and the arm is at rest. After
  `release_dwell_s` the arm retracts with the gripper open.
- **protective_stop**: a critical service lost or silent (see `watchdog`): stop, repeated,
  and stay stopped; the episode ends with the service named.

The rules of each phase are in `phases`, the stop rules in `stops`, the episode's record and
summary in `episode`. All times are the local monotonic clock (s); positions are the scene's
`base` frame (m).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from services.supervisor.config import SupervisorConfig
from services.supervisor.episode import Episode
from services.supervisor.phases import PHASE_TICKS
from services.supervisor.stops import (
    STOPPED_PHASES,
    StopKeeper,
    arm_at_rest,
    goal_imminent,
    protective_stop_applies,
    release_applies,
)
from services.supervisor.tick_io import Actions, Snapshot

#: Phases after an episode, or before the first: no goal is sent (again).
OUTSIDE_EPISODE_PHASES = ("idle", "done", "failed")
#: The phase an episode's outcome ends in (``done`` for any other outcome).
TERMINAL_PHASES = {"protective_stop": "protective_stop", "failed": "failed"}


class Sequencer:
    """The handover state machine (see the module docstring).

    Args:
        config: supervisor settings.
        home_rad: the arm's home posture for the retract (7 joints, rad).
    """

    def __init__(self, config: SupervisorConfig, home_rad: Sequence[float]) -> None:
        self.config = config
        self.home_rad = [float(v) for v in home_rad]
        self.phase = "idle"
        self.reason = "waiting for the services"
        self.phase_since_s = 0.0
        self.grip_request = "open"
        self.episode_id = 0
        self.episodes_done = 0
        self.episode: Episode | None = None
        self.finished = False
        self.stops = StopKeeper(config.stop_repeat_s)
        self._done_s: float | None = None

    # ------------------------------------------------------------------ verbs (for `phases`)
    def elapsed_s(self, now_s: float) -> float:
        """Time in the current phase at `now_s`, s."""
        return max(0.0, now_s - self.phase_since_s)

    def enter(self, phase: str, now_s: float, reason: str, actions: Actions) -> None:
        """Enter `phase` at `now_s`, counting the time of the phase left."""
        ep = self.episode
        if ep is not None and self.phase not in OUTSIDE_EPISODE_PHASES:
            ep.add_time(self.phase, self.elapsed_s(now_s))
        self.phase, self.reason, self.phase_since_s = phase, reason, now_s
        actions.state_changed = True

    def send_goal(self, kind: str, now_s: float, actions: Actions, **fields: Any) -> None:
        """A new motion goal of `kind` (see `Episode.new_goal`)."""
        assert self.episode is not None
        actions.goal = self.episode.new_goal(kind, now_s, **fields)

    def step(self, name: str, now_s: float, actions: Actions) -> None:
        """Enter step `name` of the current phase (the pick's approach, down, close, lift)."""
        ep = self.episode
        assert ep is not None
        ep.step, ep.step_since_s = name, now_s
        self.reason = name
        actions.state_changed = True

    def stop(self, now_s: float, reason: str, protective: bool, actions: Actions) -> None:
        """Stop the arm (a goal is never sent again after a stop)."""
        if self.episode is not None:
            self.episode.goal_unacknowledged = None
        actions.stop = self.stops.send(now_s, reason, protective)

    def finish(self, now_s: float, outcome: str, reason: str, actions: Actions) -> None:
        """End the episode: summary, phase done (or protective_stop/failed stays)."""
        ep = self.episode
        assert ep is not None
        ep.outcome, ep.outcome_reason = outcome, reason
        terminal = TERMINAL_PHASES.get(outcome, "done")
        if terminal != self.phase:
            self.enter(terminal, now_s, reason, actions)
        else:
            ep.add_time(self.phase, self.elapsed_s(now_s))
        actions.summary = ep.summary()
        ep.summary_sent = True
        self.episodes_done += 1
        self._done_s = now_s
        if outcome == "protective_stop":
            self.finished = True  # never move again after a protective stop
        elif self.config.episodes and self.episodes_done >= self.config.episodes:
            self.finished = True

    def retract(self, now_s: float, reason: str, outcome: str, grip: str, actions: Actions) -> None:
        """Go home with the gripper at `grip`; the episode ends with `outcome` once there."""
        ep = self.episode
        assert ep is not None
        ep.outcome, ep.outcome_reason = outcome, reason
        self.grip_request = grip
        self.enter("retract", now_s, reason, actions)
        self.send_goal("retract", now_s, actions, joint_target_rad=self.home_rad)

    # ------------------------------------------------------------------ events
    def start_episode(self, now_s: float) -> Actions:
        """Begin the next episode (locate)."""
        actions = Actions()
        self.episode_id += 1
        self.episode = Episode(self.episode_id, now_s)
        self.grip_request = "open"
        self._done_s = None
        self.enter("locate", now_s, "looking for the receiver and the object", actions)
        return actions

    def on_release(self, now_s: float, detail: str = "release event") -> Actions:
        """The gripper released the object: stop all arm motion at once."""
        actions = Actions()
        ep = self.episode
        if ep is None or not release_applies(self.phase, ep):
            return actions
        ep.release_s = now_s
        self.grip_request = "open"
        self.stop(now_s, "release", False, actions)
        self.enter("released", now_s, f"{detail}: arm stopped", actions)
        return actions

    def on_fault(self, now_s: float, fault_text: str, critical: bool) -> Actions:
        """A watched service is lost or silent (`fault_text` names it)."""
        actions = Actions()
        ep = self.episode
        if ep is not None:
            ep.faults.append(fault_text)
        if not protective_stop_applies(self.phase, ep, critical):
            return actions
        self.stop(now_s, f"protective stop: {fault_text}", True, actions)
        if ep is None:
            self.episode = Episode(self.episode_id, now_s)
        self.enter("protective_stop", now_s, fault_text, actions)
        self.finish(now_s, "protective_stop", f"protective stop: {fault_text}", actions)
        return actions

    # ------------------------------------------------------------------ the tick
    @property
    def resting(self) -> bool:
        """True once the last episode has ended normally (``done`` or ``failed``, no episode
        to come): nothing but the watchdog can act, so the node may tick more slowly. A
        protective stop is not resting: its stop is repeated at the full rate."""
        return self.finished and self.phase in ("done", "failed")

    def tick(self, snap: Snapshot) -> Actions:
        """One sequencer step at `snap.now_s`."""
        actions = self._tick_phase(snap)
        if self.phase in STOPPED_PHASES and actions.goal is None:
            self._repeat_stop(snap, actions)  # after the phase's step: never with a new goal
        elif actions.goal is None and actions.stop is None:
            self._repeat_goal(snap, actions)
        return actions

    def _repeat_stop(self, snap: Snapshot, actions: Actions) -> None:
        """Send the stop again when due (`StopKeeper.again`)."""
        now = snap.now_s
        imminent = goal_imminent(self.phase, self.episode, self.elapsed_s(now), now, self.config)
        stop = self.stops.again(now, snap.motion, arm_at_rest(snap.joints, self.config.rest_speed_rad_s), imminent)
        if stop is not None:
            actions.stop = stop

    def _repeat_goal(self, snap: Snapshot, actions: Actions) -> None:
        """Send the current goal again (same `goal_id`) every `goal_repeat_s` until the motion
        service reports on it: a goal lost on the bus would otherwise leave the episode
        waiting for a move that never started, until the move's time-out."""
        ep = self.episode
        if ep is None or self.phase in OUTSIDE_EPISODE_PHASES:
            return
        goal = ep.goal_to_repeat(snap.motion, snap.now_s, self.config.goal_repeat_s)
        if goal is not None:
            actions.goal = goal
            actions.goal_repeated = True

    def _tick_phase(self, snap: Snapshot) -> Actions:
        actions = Actions()
        now, cfg, ep = snap.now_s, self.config, self.episode
        if ep is None or self.phase == "idle":
            return actions
        if self.phase in ("done", "failed"):
            if not self.finished and self._done_s is not None and now - self._done_s >= cfg.between_episodes_s:
                actions.merge(self.start_episode(now))
            return actions
        if self.phase == "protective_stop":
            return actions
        if snap.gripper is not None and snap.gripper.released and self.phase in ("transfer", "reach", "hold"):
            return actions.merge(self.on_release(now, "gripper state: released"))
        PHASE_TICKS[self.phase](self, snap, actions)
        return actions
