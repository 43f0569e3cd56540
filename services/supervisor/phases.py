"""What each phase of the handover does at a tick (pure, no I/O, no clock): the rules of
`core.Sequencer`'s phases from ``locate`` to ``retract``; the sequencer keeps the state and
the verbs (enter a phase, send a goal, stop, retract, finish).

All times are the local monotonic clock (s); positions are the scene's `base` frame (m).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from bus_schema.messages import TransferTarget
from services.supervisor.stops import arm_at_rest
from services.supervisor.tick_io import Actions, Snapshot

if TYPE_CHECKING:
    from services.supervisor.core import Sequencer

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
#: The wrist must feel the object's weight this long before the lift, s.
GRASP_SETTLE_S = 0.1


def human_ok(snap: Snapshot, fresh_s: float = HUMAN_FRESH_S) -> bool:
    """True when the receiver is tracked and its state is at most `fresh_s` (s) old."""
    h = snap.human
    return h is not None and h.tracked and snap.now_s - snap.human_rx_s <= fresh_s


def tick_locate(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """Wait for a tracked receiver and the object on the table, then approach from above.

    The only phase that reads the object estimate: the tracker detects at full rate only in
    the phases of `services.tracker.core.OBJECT_PHASES`, so a phase that reads `snap.obj` too
    must join them."""
    ep, now = seq.episode, snap.now_s
    assert ep is not None
    obj_ok = snap.obj is not None and snap.obj.found and now - snap.obj_rx_s <= OBJECT_FRESH_S
    if human_ok(snap) and obj_ok:
        assert snap.obj is not None
        ep.object_position_m = np.array(snap.obj.position_m, dtype=float)
        ep.object_mass_kg = float(snap.obj.mass_kg)
        seq.enter("pick", now, "approach", actions)
        seq.step("approach", now, actions)
        above = ep.object_position_m + np.array([0.0, 0.0, seq.config.pregrasp_height_m])
        seq.send_goal("pick", now, actions, position_base_m=tuple(above))
    elif seq.elapsed_s(now) > seq.config.locate_timeout_s:
        missing = [n for n, ok in (("the receiver", human_ok(snap)), ("the object", obj_ok)) if not ok]
        seq.finish(now, "failed", f"locate: the tracker did not find {' and '.join(missing)} "
                                  f"within {seq.config.locate_timeout_s:g} s", actions)


def tick_pick(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """Approach, go down, close until the wrist feels the weight, lift."""
    ep, now, cfg = seq.episode, snap.now_s, seq.config
    assert ep is not None and ep.object_position_m is not None
    status = ep.goal_status(snap.motion)
    if status == "failed":
        seq.finish(now, "failed", f"pick ({ep.step}): motion failed: {snap.motion.reason if snap.motion else ''}",
                   actions)
        return
    if ep.step in ("approach", "down", "lift") and now - ep.goal_sent_s > cfg.move_timeout_s:
        seq.finish(now, "failed", f"pick ({ep.step}): the move took longer than {cfg.move_timeout_s:g} s", actions)
        return
    if ep.step == "approach" and status == "reached":
        seq.step("down", now, actions)
        seq.send_goal("pick", now, actions, position_base_m=tuple(ep.object_position_m))
    elif ep.step == "down" and status == "reached":
        seq.step("close", now, actions)
        seq.grip_request = "carry"
    elif ep.step == "close":
        weight = ep.object_mass_kg * GRAVITY_M_S2
        load = snap.wrench.force_n[1] if snap.wrench is not None else 0.0
        if load >= cfg.grasp_load_fraction * weight and weight > 0:
            ep.grasp_since_s = ep.grasp_since_s or now
            if now - ep.grasp_since_s >= GRASP_SETTLE_S:
                seq.step("lift", now, actions)
                lifted = ep.object_position_m + np.array([0.0, 0.0, cfg.lift_height_m])
                seq.send_goal("pick", now, actions, position_base_m=tuple(lifted))
        else:
            ep.grasp_since_s = None
        if ep.step == "close" and now - ep.step_since_s > cfg.grasp_timeout_s:
            seq.finish(now, "failed", f"grasp failed: the wrist feels F_sy = {load:.2f} N, expected at least "
                                      f"{cfg.grasp_load_fraction * weight:.2f} N (is the object in the gripper?)",
                       actions)
    elif ep.step == "lift" and status == "reached":
        seq.enter("plan", now, "waiting for the transfer target", actions)


def tick_plan(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """Reach once a current target and a tracked receiver are there (and a stop is behind)."""
    now = snap.now_s
    t = snap.target
    settled = seq.stops.settled(now)  # after a hold: the stop is behind us
    if t is not None and now - snap.target_rx_s <= TARGET_FRESH_S and human_ok(snap) and settled:
        send_reach(seq, snap, t, actions, "reach to the DJT transfer point")
    elif seq.elapsed_s(now) > seq.config.plan_timeout_s:
        what = "no transfer target from the planner" if t is None or now - snap.target_rx_s > TARGET_FRESH_S \
            else "the receiver is not tracked"
        seq.retract(now, f"plan: {what} within {seq.config.plan_timeout_s:g} s", "failed", "carry", actions)


def send_reach(seq: Sequencer, snap: Snapshot, t: TransferTarget, actions: Actions, reason: str) -> None:
    """A `transfer` goal to target `t`, with the receiver's hand for the speed cap."""
    ep, now = seq.episode, snap.now_s
    assert ep is not None
    ep.reach_position_m = np.array(t.position_base_m, dtype=float)
    ep.receiver_posture = t.receiver_posture
    seq.grip_request = "transfer"
    hand = snap.human.hand_position_m if snap.human is not None and snap.human.tracked else None
    if seq.phase != "reach":
        seq.enter("reach", now, reason, actions)
    seq.send_goal("transfer", now, actions, position_base_m=tuple(t.position_base_m),
                  duration_s=t.reach_duration_s, peak_speed_m_s=t.peak_speed_m_s,
                  receiver_hand_position_m=hand)


def tick_reach(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """Hold when the receiver is lost; transfer when reached; re-plan early on a moved target."""
    ep, now, cfg = seq.episode, snap.now_s, seq.config
    assert ep is not None
    if not human_ok(snap, cfg.human_lost_s):
        seq.stop(now, "receiver lost: holding", False, actions)
        seq.enter("hold", now, "receiver lost: arm holds", actions)
        return
    status = ep.goal_status(snap.motion)
    if status == "reached":
        ep.transfer_start_grip_n = snap.gripper.grip_force_n if snap.gripper is not None else 0.0
        ep.peak_grip_n = ep.transfer_start_grip_n
        seq.enter("transfer", now, "at the transfer point: the gripper decides the release", actions)
        return
    if status == "failed":
        seq.retract(now, f"reach failed: {snap.motion.reason if snap.motion else ''}", "failed", "carry", actions)
        return
    if now - ep.goal_sent_s > cfg.reach_timeout_s:
        seq.retract(now, f"reach took longer than {cfg.reach_timeout_s:g} s", "failed", "carry", actions)
        return
    t = snap.target
    early = (snap.motion is not None and snap.motion.goal_id == ep.goal_id
             and snap.motion.progress < REPLAN_BEFORE_PROGRESS)
    if (t is not None and ep.reach_position_m is not None and now - snap.target_rx_s <= TARGET_FRESH_S
            and early and ep.replans < cfg.max_replans
            and float(np.linalg.norm(np.array(t.position_base_m) - ep.reach_position_m)) > cfg.replan_threshold_m):
        ep.replans += 1
        send_reach(seq, snap, t, actions, f"receiver moved: re-plan {ep.replans}")
        seq.reason = f"receiver moved: re-plan {ep.replans}"


def tick_hold(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """The arm holds: re-plan when the receiver is back, abort when lost too long."""
    now = snap.now_s
    if human_ok(snap):
        seq.enter("plan", now, "receiver back: re-plan", actions)
    elif seq.elapsed_s(now) > seq.config.human_return_s:
        seq.retract(now, f"receiver lost for {seq.config.human_return_s:g} s: abort", "aborted", "carry", actions)


def tick_transfer(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """Hold at the transfer point (the gripper decides the release) until the time-out."""
    ep, now = seq.episode, snap.now_s
    assert ep is not None
    g = snap.gripper
    if g is not None:
        ep.peak_grip_n = max(ep.peak_grip_n, g.grip_force_n)
        slip = "object slipping: the gripper regrasps, the arm holds" if g.mode == "slip" else \
            "at the transfer point: the gripper decides the release"
        if slip != seq.reason:
            seq.reason = slip
            actions.state_changed = True
    if seq.elapsed_s(now) > seq.config.transfer_timeout_s:
        seq.retract(now, f"the receiver did not take the object within {seq.config.transfer_timeout_s:g} s",
                    "timeout", "carry", actions)


def tick_released(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """After the release: retract once the arm has been at rest for the dwell."""
    ep, now = seq.episode, snap.now_s
    assert ep is not None and ep.release_s is not None
    if arm_at_rest(snap.joints, seq.config.rest_speed_rad_s):
        if ep.at_rest_since_s is None:
            ep.at_rest_since_s = now
            ep.release_to_stop_s = max(0.0, snap.joints_rx_s - ep.release_s)
    else:
        ep.at_rest_since_s = None
    if (ep.at_rest_since_s is not None and now - ep.at_rest_since_s >= seq.config.release_dwell_s
            and seq.stops.settled(now)):
        seq.retract(now, "released to the receiver", "released", "open", actions)


def tick_retract(seq: Sequencer, snap: Snapshot, actions: Actions) -> None:
    """End the episode when home is reached (failed when the retract fails)."""
    ep, now = seq.episode, snap.now_s
    assert ep is not None
    status = ep.goal_status(snap.motion)
    if status == "reached":
        seq.finish(now, ep.outcome, ep.outcome_reason, actions)
    elif status == "failed" or now - ep.goal_sent_s > seq.config.move_timeout_s:
        why = (snap.motion.reason if status == "failed" and snap.motion
               else f"longer than {seq.config.move_timeout_s:g} s")
        seq.finish(now, "failed", f"{ep.outcome_reason}; retract failed: {why}", actions)


#: The tick of each phase that moves the episode on (the others wait or repeat a stop).
PHASE_TICKS: dict[str, Callable[[Sequencer, Snapshot, Actions], None]] = {
    "locate": tick_locate,
    "pick": tick_pick,
    "plan": tick_plan,
    "reach": tick_reach,
    "hold": tick_hold,
    "transfer": tick_transfer,
    "released": tick_released,
    "retract": tick_retract,
}
