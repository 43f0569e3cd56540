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

All times are the local monotonic clock (s); positions are Baxter's `base` frame (m).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import msgspec
import numpy as np

from bus_schema.messages import (
    GripperState,
    HumanState,
    JointState,
    MotionStatus,
    ObjectEstimate,
    TransferTarget,
    WristWrench,
)
from services.supervisor.config import SupervisorConfig

GRAVITY_M_S2 = 9.81
#: The human state and the object estimate count as fresh for this long (s).
HUMAN_FRESH_S = 0.5
OBJECT_FRESH_S = 1.0
#: A transfer target counts as current for this long (the planner republishes at 5 Hz), s.
TARGET_FRESH_S = 1.0
#: A moved target only starts a new reach before this fraction of the reach: later the arm
#: is near the receiver's hand, where the motion service caps the speed, and the receiver's
#: own hand closes the remaining gap.
REPLAN_BEFORE_PROGRESS = 0.5
#: Once a stop is confirmed, it is still repeated this often (s): a stop is never let go of.
STOP_KEEPALIVE_S = 0.5
#: A new goal leaves at least this long after the last stop (s): the motion service and the
#: bridge apply a stop that reaches them together with (or just after) a goal to that goal,
#: so a keep-alive stop sent right before the retract or a re-planned reach would cancel it.
STOP_SETTLE_S = 0.1


class TargetFilter:
    """The planner's transfer target, steadied: the component-wise median of the targets
    received over the last `window_s` seconds. The DJT optimum moves a few cm from frame to
    frame with the tracker's body estimates; a median keeps that noise from looking like a
    receiver who moved (which would start a new reach).

    Args:
        window_s: length of the median window, s.
    """

    def __init__(self, window_s: float = 1.0) -> None:
        self.window_s = window_s
        self._items: list[tuple[float, TransferTarget]] = []
        self._current: TransferTarget | None = None  # of the window as it is now
        self._stale = True

    def offer(self, target: TransferTarget, rx_s: float) -> None:
        self._items.append((rx_s, target))
        self._stale = True

    def current(self, now_s: float) -> TransferTarget | None:
        """The latest target with its position replaced by the window's median (None when
        nothing was received within the window). Computed again only when the window's
        contents changed (the supervisor asks at 100 Hz; targets come at about 5 Hz)."""
        items = self._items
        first = 0
        while first < len(items) and now_s - items[first][0] > self.window_s:
            first += 1
        if first:
            del items[:first]
            self._stale = True
        if not items:
            self._current = None
            return None
        if self._stale:
            latest = items[-1][1]
            median = np.median(np.array([m.position_base_m for _, m in items]), axis=0)
            self._current = msgspec.structs.replace(latest, position_base_m=tuple(float(v) for v in median))
            self._stale = False
        return self._current


@dataclass
class Snapshot:
    """What the supervisor knows at one tick: the latest decoded messages and their local
    receive times (monotonic s; −inf when never received)."""

    now_s: float
    human: HumanState | None = None
    human_rx_s: float = -math.inf
    obj: ObjectEstimate | None = None
    obj_rx_s: float = -math.inf
    target: TransferTarget | None = None
    target_rx_s: float = -math.inf
    motion: MotionStatus | None = None
    gripper: GripperState | None = None
    wrench: WristWrench | None = None
    joints: JointState | None = None
    joints_rx_s: float = -math.inf


@dataclass
class Actions:
    """What the node must publish after a call: a motion goal, a stop, an episode summary
    (fields without header), and whether the state changed."""

    goal: dict[str, Any] | None = None
    goal_repeated: bool = False  # `goal` is a copy of one already sent (no report on it yet)
    stop: dict[str, Any] | None = None
    summary: dict[str, Any] | None = None
    state_changed: bool = False

    def merge(self, other: Actions) -> Actions:
        if other.goal:
            self.goal_repeated = other.goal_repeated
        self.goal = other.goal or self.goal
        self.stop = other.stop or self.stop
        self.summary = other.summary or self.summary
        self.state_changed = self.state_changed or other.state_changed
        return self


@dataclass
class _Episode:
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
        self.episode: _Episode | None = None
        self.finished = False
        self._stop_reason = ""
        self._stop_protective = False
        self._stop_confirmed = False
        self._last_stop_s = -math.inf
        self._done_s: float | None = None

    # ------------------------------------------------------------------ helpers
    def elapsed_s(self, now_s: float) -> float:
        return max(0.0, now_s - self.phase_since_s)

    def _enter(self, phase: str, now_s: float, reason: str, actions: Actions) -> None:
        ep = self.episode
        if ep is not None and self.phase not in ("idle", "done", "failed"):
            ep.durations_s[self.phase] = ep.durations_s.get(self.phase, 0.0) + self.elapsed_s(now_s)
        self.phase, self.reason, self.phase_since_s = phase, reason, now_s
        actions.state_changed = True

    def _goal(self, kind: str, now_s: float, actions: Actions, **fields: Any) -> None:
        ep = self.episode
        assert ep is not None
        ep.goal_count += 1
        ep.goal_id = f"e{ep.episode_id}-{kind}-{ep.goal_count}"
        ep.goal_sent_s = ep.goal_repeated_s = now_s
        actions.goal = {"goal_id": ep.goal_id, "kind": kind, **fields}
        ep.goal_unacknowledged = dict(actions.goal)

    def _step(self, name: str, now_s: float, actions: Actions) -> None:
        ep = self.episode
        assert ep is not None
        ep.step, ep.step_since_s = name, now_s
        self.reason = name
        actions.state_changed = True

    def _goal_status(self, snap: Snapshot) -> str | None:
        """The motion state of the current goal (None while the motion service has not
        reported on it yet)."""
        m, ep = snap.motion, self.episode
        if m is None or ep is None or m.goal_id != ep.goal_id:
            return None
        return m.state

    def _at_rest(self, snap: Snapshot) -> bool:
        j = snap.joints
        return (j is not None and bool(j.velocity_rad_s)
                and max(abs(v) for v in j.velocity_rad_s) < self.config.rest_speed_rad_s)

    def _human_ok(self, snap: Snapshot, fresh_s: float = HUMAN_FRESH_S) -> bool:
        h = snap.human
        return h is not None and h.tracked and snap.now_s - snap.human_rx_s <= fresh_s

    def _stop(self, now_s: float, reason: str, protective: bool, actions: Actions) -> None:
        if self.episode is not None:
            self.episode.goal_unacknowledged = None  # a goal is never sent again after a stop
        self._stop_reason, self._stop_protective = reason, protective
        self._stop_confirmed = False
        self._last_stop_s = now_s
        actions.stop = {"reason": reason, "protective": protective}

    def _repeat_stop(self, snap: Snapshot, actions: Actions) -> None:
        """Send the stop again until the motion service says stopped and the arm is at rest
        (a lost stop message is sent again), then now and then."""
        if not self._stop_confirmed:
            m = snap.motion
            self._stop_confirmed = m is not None and m.state in ("stopped", "idle", "failed") and self._at_rest(snap)
        period = STOP_KEEPALIVE_S if self._stop_confirmed else self.config.stop_repeat_s
        if self._stop_confirmed and self._goal_imminent(snap.now_s):
            return  # the arm is at rest and stopped: keep the next goal clear of a stop
        if snap.now_s - self._last_stop_s >= period:
            self._last_stop_s = snap.now_s
            actions.stop = {"reason": self._stop_reason, "protective": self._stop_protective}

    def _goal_imminent(self, now_s: float) -> bool:
        """A goal is due within `STOP_SETTLE_S` (the retract after the release dwell, or the
        abort after the receiver was lost too long)."""
        ep, cfg = self.episode, self.config
        if self.phase == "released" and ep is not None and ep.at_rest_since_s is not None:
            return now_s - ep.at_rest_since_s >= cfg.release_dwell_s - STOP_SETTLE_S
        if self.phase == "hold":
            return self.elapsed_s(now_s) >= cfg.human_return_s - STOP_SETTLE_S
        return False

    def _finish(self, now_s: float, outcome: str, reason: str, actions: Actions) -> None:
        """End the episode: summary, phase done (or protective_stop/failed stays)."""
        ep = self.episode
        assert ep is not None
        ep.outcome, ep.outcome_reason = outcome, reason
        terminal = {"protective_stop": "protective_stop", "failed": "failed"}.get(outcome, "done")
        if terminal != self.phase:
            self._enter(terminal, now_s, reason, actions)
        else:
            ep.durations_s[self.phase] = ep.durations_s.get(self.phase, 0.0) + self.elapsed_s(now_s)
        actions.summary = self._summary()
        ep.summary_sent = True
        self.episodes_done += 1
        self._done_s = now_s
        if outcome == "protective_stop":
            self.finished = True  # never move again after a protective stop
        elif self.config.episodes and self.episodes_done >= self.config.episodes:
            self.finished = True

    def _summary(self) -> dict[str, Any]:
        ep = self.episode
        assert ep is not None
        overshoot = 0.0
        if ep.transfer_start_grip_n is not None:
            overshoot = max(0.0, ep.peak_grip_n - ep.transfer_start_grip_n)
        return {
            "episode_id": ep.episode_id,
            "outcome": ep.outcome,
            "reason": ep.outcome_reason[:512],
            "transfer_point_base_m": (None if ep.reach_position_m is None
                                      else tuple(float(v) for v in ep.reach_position_m)),
            "receiver_posture": ep.receiver_posture if ep.receiver_posture in ("standing", "sitting") else "unknown",
            "phase_durations_s": {k: min(v, 86400.0) for k, v in list(ep.durations_s.items())[:16]},
            "peak_grip_force_n": ep.peak_grip_n,
            "force_overshoot_n": overshoot,
            "release_to_stop_s": ep.release_to_stop_s,
            "replans": ep.replans,
            "faults": [f[:512] for f in ep.faults[:32]],
        }

    def _retract(self, now_s: float, reason: str, outcome: str, grip: str, actions: Actions) -> None:
        ep = self.episode
        assert ep is not None
        ep.outcome, ep.outcome_reason = outcome, reason
        self.grip_request = grip
        self._enter("retract", now_s, reason, actions)
        self._goal("retract", now_s, actions, joint_target_rad=self.home_rad)

    # ------------------------------------------------------------------ events
    def start_episode(self, now_s: float) -> Actions:
        """Begin the next episode (locate)."""
        actions = Actions()
        self.episode_id += 1
        self.episode = _Episode(self.episode_id, now_s)
        self.grip_request = "open"
        self._done_s = None
        self._enter("locate", now_s, "looking for the receiver and the object", actions)
        return actions

    def on_release(self, now_s: float, detail: str = "release event") -> Actions:
        """The gripper released the object: stop all arm motion at once."""
        actions = Actions()
        ep = self.episode
        if ep is None or self.phase not in ("reach", "transfer", "hold") or ep.release_s is not None:
            return actions
        ep.release_s = now_s
        self.grip_request = "open"
        self._stop(now_s, "release", False, actions)
        self._enter("released", now_s, f"{detail}: arm stopped", actions)
        return actions

    def on_fault(self, now_s: float, fault_text: str, critical: bool) -> Actions:
        """A watched service is lost or silent (`fault_text` names it)."""
        actions = Actions()
        ep = self.episode
        if ep is not None:
            ep.faults.append(fault_text)
        if not critical:
            return actions
        if self.phase in ("idle", "done", "failed", "protective_stop") and (ep is None or ep.summary_sent):
            if self.phase == "idle" and ep is None:
                return actions  # before the first episode: the start waits for the services
            if self.phase == "protective_stop":
                return actions
        self._stop(now_s, f"protective stop: {fault_text}", True, actions)
        if ep is None:
            self.episode = ep = _Episode(self.episode_id, now_s)
        self._enter("protective_stop", now_s, fault_text, actions)
        self._finish(now_s, "protective_stop", f"protective stop: {fault_text}", actions)
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
        if self.phase in ("released", "protective_stop", "hold") and actions.goal is None:
            self._repeat_stop(snap, actions)  # after the phase's step: never with a new goal
        elif actions.goal is None and actions.stop is None:
            self._repeat_goal(snap, actions)
        return actions

    def _repeat_goal(self, snap: Snapshot, actions: Actions) -> None:
        """Send the current goal again (same `goal_id`) every `goal_repeat_s` until the motion
        service reports on it: a goal lost on the bus would otherwise leave the episode
        waiting for a move that never started, until the move's time-out."""
        ep = self.episode
        if ep is None or ep.goal_unacknowledged is None or self.phase in ("idle", "done", "failed"):
            return
        if self._goal_status(snap) is not None:
            ep.goal_unacknowledged = None
            return
        if snap.now_s - ep.goal_repeated_s >= self.config.goal_repeat_s:
            ep.goal_repeated_s = snap.now_s
            ep.goal_repeats += 1
            actions.goal = dict(ep.goal_unacknowledged)
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
        handler = getattr(self, f"_tick_{self.phase}")
        handler(snap, actions)
        return actions

    def _tick_locate(self, snap: Snapshot, actions: Actions) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None
        obj_ok = snap.obj is not None and snap.obj.found and now - snap.obj_rx_s <= OBJECT_FRESH_S
        if self._human_ok(snap) and obj_ok:
            assert snap.obj is not None
            ep.object_position_m = np.array(snap.obj.position_m, dtype=float)
            ep.object_mass_kg = float(snap.obj.mass_kg)
            self._enter("pick", now, "approach", actions)
            self._step("approach", now, actions)
            above = ep.object_position_m + np.array([0.0, 0.0, self.config.pregrasp_height_m])
            self._goal("pick", now, actions, position_base_m=tuple(above))
        elif self.elapsed_s(now) > self.config.locate_timeout_s:
            missing = [n for n, ok in (("the receiver", self._human_ok(snap)), ("the object", obj_ok)) if not ok]
            self._finish(now, "failed", f"locate: the tracker did not find {' and '.join(missing)} "
                                        f"within {self.config.locate_timeout_s:g} s", actions)

    def _tick_pick(self, snap: Snapshot, actions: Actions) -> None:
        ep, now, cfg = self.episode, snap.now_s, self.config
        assert ep is not None and ep.object_position_m is not None
        status = self._goal_status(snap)
        if status == "failed":
            self._finish(now, "failed", f"pick ({ep.step}): motion failed: {snap.motion.reason if snap.motion else ''}",
                         actions)
            return
        if ep.step in ("approach", "down", "lift") and now - ep.goal_sent_s > cfg.move_timeout_s:
            self._finish(now, "failed", f"pick ({ep.step}): the move took longer than {cfg.move_timeout_s:g} s",
                         actions)
            return
        if ep.step == "approach" and status == "reached":
            self._step("down", now, actions)
            self._goal("pick", now, actions, position_base_m=tuple(ep.object_position_m))
        elif ep.step == "down" and status == "reached":
            self._step("close", now, actions)
            self.grip_request = "carry"
        elif ep.step == "close":
            weight = ep.object_mass_kg * GRAVITY_M_S2
            load = snap.wrench.force_n[1] if snap.wrench is not None else 0.0
            if load >= cfg.grasp_load_fraction * weight and weight > 0:
                ep.grasp_since_s = ep.grasp_since_s or now
                if now - ep.grasp_since_s >= 0.1:
                    self._step("lift", now, actions)
                    lifted = ep.object_position_m + np.array([0.0, 0.0, cfg.lift_height_m])
                    self._goal("pick", now, actions, position_base_m=tuple(lifted))
            else:
                ep.grasp_since_s = None
            if ep.step == "close" and now - ep.step_since_s > cfg.grasp_timeout_s:
                self._finish(now, "failed", f"grasp failed: the wrist feels F_sy = {load:.2f} N, expected at least "
                                            f"{cfg.grasp_load_fraction * weight:.2f} N (is the object in the gripper?)",
                             actions)
        elif ep.step == "lift" and status == "reached":
            self._enter("plan", now, "waiting for the transfer target", actions)

    def _tick_plan(self, snap: Snapshot, actions: Actions) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None
        t = snap.target
        settled = now - self._last_stop_s >= STOP_SETTLE_S  # after a hold: the stop is behind us
        if t is not None and now - snap.target_rx_s <= TARGET_FRESH_S and self._human_ok(snap) and settled:
            self._send_reach(snap, t, actions, "reach to the DJT transfer point")
        elif self.elapsed_s(now) > self.config.plan_timeout_s:
            what = "no transfer target from the planner" if t is None or now - snap.target_rx_s > TARGET_FRESH_S \
                else "the receiver is not tracked"
            self._retract(now, f"plan: {what} within {self.config.plan_timeout_s:g} s", "failed", "carry", actions)

    def _send_reach(self, snap: Snapshot, t: TransferTarget, actions: Actions, reason: str) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None
        ep.reach_position_m = np.array(t.position_base_m, dtype=float)
        ep.receiver_posture = t.receiver_posture
        self.grip_request = "transfer"
        hand = snap.human.hand_position_m if snap.human is not None and snap.human.tracked else None
        if self.phase != "reach":
            self._enter("reach", now, reason, actions)
        self._goal("transfer", now, actions, position_base_m=tuple(t.position_base_m),
                   duration_s=t.reach_duration_s, peak_speed_m_s=t.peak_speed_m_s,
                   receiver_hand_position_m=hand)

    def _tick_reach(self, snap: Snapshot, actions: Actions) -> None:
        ep, now, cfg = self.episode, snap.now_s, self.config
        assert ep is not None
        if not self._human_ok(snap, cfg.human_lost_s):
            self._stop(now, "receiver lost: holding", False, actions)
            self._enter("hold", now, "receiver lost: arm holds", actions)
            return
        status = self._goal_status(snap)
        if status == "reached":
            ep.transfer_start_grip_n = snap.gripper.grip_force_n if snap.gripper is not None else 0.0
            ep.peak_grip_n = ep.transfer_start_grip_n
            self._enter("transfer", now, "at the transfer point: the gripper decides the release", actions)
            return
        if status == "failed":
            self._retract(now, f"reach failed: {snap.motion.reason if snap.motion else ''}", "failed", "carry", actions)
            return
        if now - ep.goal_sent_s > cfg.reach_timeout_s:
            self._retract(now, f"reach took longer than {cfg.reach_timeout_s:g} s", "failed", "carry", actions)
            return
        t = snap.target
        early = (snap.motion is not None and snap.motion.goal_id == ep.goal_id
                 and snap.motion.progress < REPLAN_BEFORE_PROGRESS)
        if (t is not None and ep.reach_position_m is not None and now - snap.target_rx_s <= TARGET_FRESH_S
                and early and ep.replans < cfg.max_replans
                and float(np.linalg.norm(np.array(t.position_base_m) - ep.reach_position_m)) > cfg.replan_threshold_m):
            ep.replans += 1
            self._send_reach(snap, t, actions, f"receiver moved: re-plan {ep.replans}")
            self.reason = f"receiver moved: re-plan {ep.replans}"

    def _tick_hold(self, snap: Snapshot, actions: Actions) -> None:
        now = snap.now_s
        if self._human_ok(snap):
            self._enter("plan", now, "receiver back: re-plan", actions)
        elif self.elapsed_s(now) > self.config.human_return_s:
            self._retract(now, f"receiver lost for {self.config.human_return_s:g} s: abort", "aborted", "carry",
                          actions)

    def _tick_transfer(self, snap: Snapshot, actions: Actions) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None
        g = snap.gripper
        if g is not None:
            ep.peak_grip_n = max(ep.peak_grip_n, g.grip_force_n)
            slip = "object slipping: the gripper regrasps, the arm holds" if g.mode == "slip" else \
                "at the transfer point: the gripper decides the release"
            if slip != self.reason:
                self.reason = slip
                actions.state_changed = True
        if self.elapsed_s(now) > self.config.transfer_timeout_s:
            self._retract(now, f"the receiver did not take the object within {self.config.transfer_timeout_s:g} s",
                          "timeout", "carry", actions)

    def _tick_released(self, snap: Snapshot, actions: Actions) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None and ep.release_s is not None
        if self._at_rest(snap):
            if ep.at_rest_since_s is None:
                ep.at_rest_since_s = now
                ep.release_to_stop_s = max(0.0, snap.joints_rx_s - ep.release_s)
        else:
            ep.at_rest_since_s = None
        if (ep.at_rest_since_s is not None and now - ep.at_rest_since_s >= self.config.release_dwell_s
                and now - self._last_stop_s >= STOP_SETTLE_S):
            self._retract(now, "released to the receiver", "released", "open", actions)

    def _tick_retract(self, snap: Snapshot, actions: Actions) -> None:
        ep, now = self.episode, snap.now_s
        assert ep is not None
        status = self._goal_status(snap)
        if status == "reached":
            self._finish(now, ep.outcome, ep.outcome_reason, actions)
        elif status == "failed" or now - ep.goal_sent_s > self.config.move_timeout_s:
            why = (snap.motion.reason if status == "failed" and snap.motion
                   else f"longer than {self.config.move_timeout_s:g} s")
            self._finish(now, "failed", f"{ep.outcome_reason}; retract failed: {why}", actions)
