"""One episode's record: the figures of the run, taken from its recording (pure, no I/O).

Every figure comes from what the stack recorded (`recording.EpisodeRecording`): the
supervisor's summary, the simulation's truth, the release event, the motion goals, statuses
and stops. The draw only labels the episode (behaviour, posture, height) and gives the
reference the transfer point is scored against (the DJT optimum of the true receiver,
`djt_reference`). Times in s, positions in `base` m, forces in N.

R2HandoverSim's five criteria (Plan, Reach, Stability, Affordance, Safe), as our scene can
define them (None: not defined for this episode):

- ``plan``: planning feasibility: a transfer goal (the reach to the DJT point) was reached
  by the motion service (its status ``reached``).
- ``reach``: reachability: the receiver's true hand came within `CONTACT_DISTANCE_M` of the
  object while the robot held it (the scene's hand reaches only as far as its arm and lean
  allow). None for an absent receiver (nobody reaches).
- ``stability``: grasp stability: the object was never dropped and slipped at most
  `CARRY_SLIP_LIMIT_M` in the pads while the robot alone held it.
- ``affordance``: not defined: the simulated object has no parts (a mass between two pads),
  so there is no region to leave free for the receiver. Always None.
- ``safe``: the arm moved at most `NEAR_HAND_SPEED_LIMIT_M_S` within `NEAR_HAND_RADIUS_M`
  of the receiver's true hand at any time of the episode (pick, approach and retract: DESIGN
  §8's target has no exception), the grip stayed within `PINCH_LIMIT_N`, and the object never
  fell. The record splits the speed before and after the release, to show which motion broke
  the limit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from services.studies.evaluation.population import EpisodeDraw
from services.studies.evaluation.recording import EpisodeRecording

#: Arm speed near the hand: within this distance of the true hand (m), at most this speed
#: (m/s) (DESIGN §8's target).
NEAR_HAND_RADIUS_M, NEAR_HAND_SPEED_LIMIT_M_S = 0.3, 0.25
#: ISO/TS 15066 quasi-static pinch limit for the hand, N (the gripper's clamp).
PINCH_LIMIT_N = 140.0
#: The scene's hand touches the object within this distance (`SceneParams.contact_distance_m`), m.
CONTACT_DISTANCE_M = 0.06
#: Largest slip in the pads while the robot alone carries the object for a stable grasp, m.
CARRY_SLIP_LIMIT_M = 0.01
#: Outcomes of an episode that never produced a summary.
NO_SUMMARY = "no_summary"


def _finite_or_none(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else float(value)


def _times(rec: EpisodeRecording) -> dict[str, float | None]:
    """Episode start (first non-idle supervisor state of episode ≥ 1), release, reach start
    (first transfer goal): time to handover and the handover itself, s."""
    start = next((t for t, episode, phase in rec.states if episode >= 1 and phase != "idle"), None)
    reach = next((t for t, _goal, kind in rec.goals if kind == "transfer"), None)
    release = rec.release_s
    return {
        "time_to_handover_s": None if start is None or release is None else release - start,
        "reach_to_release_s": None if reach is None or release is None else release - reach,
    }


def _near_hand(rec: EpisodeRecording) -> dict[str, float | None]:
    """Closest approach of the tool to the receiver's true hand, and the arm's peak speed
    within `NEAR_HAND_RADIUS_M` of it: over the episode, before the release (the approach,
    the whole episode when nothing was released) and after it (the retract), m and m/s."""
    truth = rec.truth
    keys = ("peak_speed_near_hand_m_s", "peak_speed_near_hand_before_release_m_s",
            "peak_speed_near_hand_after_release_m_s")
    if truth.t_s.size == 0:
        return {"min_tool_hand_distance_m": None, **dict.fromkeys(keys)}
    distance = np.linalg.norm(truth.tool_m - truth.hand_m, axis=1)
    near = distance <= NEAR_HAND_RADIUS_M
    after = truth.t_s >= rec.release_s if rec.release_s is not None else np.zeros(truth.t_s.size, dtype=bool)

    def peak(pick: np.ndarray) -> float:
        return float(truth.tool_speed_m_s[pick].max()) if pick.any() else 0.0

    return {"min_tool_hand_distance_m": float(distance.min()),
            **dict(zip(keys, (peak(near), peak(near & ~after), peak(near & after)), strict=True))}


def _criteria(rec: EpisodeRecording, draw: EpisodeDraw, dropped: bool, peak_grip_n: float | None,
              peak_speed_near_hand: float | None) -> dict[str, bool | None]:
    truth = rec.truth
    transfer_goals = {goal for _t, goal, kind in rec.goals if kind == "transfer"}
    plan = any(goal in transfer_goals and state == "reached" for _t, goal, state, _r in rec.statuses)
    robot_holds = np.isin(truth.held_by, ["gripper", "both"])
    reach: bool | None = None
    if draw.behaviour != "absent":
        gap = np.linalg.norm(truth.hand_m - truth.object_m, axis=1)
        reach = bool(robot_holds.any() and gap[robot_holds].min() <= CONTACT_DISTANCE_M)
    carry = truth.held_by == "gripper"
    carry_slip = float(np.abs(truth.slip_m[carry]).max()) if carry.any() else 0.0
    safe = (peak_speed_near_hand is not None and peak_speed_near_hand <= NEAR_HAND_SPEED_LIMIT_M_S
            and (peak_grip_n or 0.0) <= PINCH_LIMIT_N and not dropped)
    return {"plan": plan, "reach": reach, "stability": (not dropped) and carry_slip <= CARRY_SLIP_LIMIT_M,
            "affordance": None, "safe": bool(safe)}


def episode_record(draw: EpisodeDraw, rec: EpisodeRecording, djt_optimum_base_m: np.ndarray | None,
                   exit_code: int, wall_s: float) -> dict[str, Any]:
    """The record of one episode (JSON-ready), from its recording `rec`.

    `djt_optimum_base_m`: the reference transfer point (true receiver), m; `exit_code` and
    `wall_s`: the launcher's exit code and the episode's wall time (start-up and shutdown
    included), s."""
    summary = rec.summary or {}
    truth = rec.truth
    dropped = bool(truth.dropped.any()) or summary.get("outcome") == "dropped"
    holder = str(truth.held_by[-1]) if truth.held_by.size else None
    outcome = summary.get("outcome", NO_SUMMARY)
    point = summary.get("transfer_point_base_m")
    error = None
    if point is not None and djt_optimum_base_m is not None:
        error = float(np.linalg.norm(np.asarray(point) - djt_optimum_base_m))
    stops = [(reason, protective) for _t, reason, protective in rec.stops]
    near = _near_hand(rec)
    peak_grip = summary.get("peak_grip_force_n")
    return {
        "episode": draw.episode, "seed": draw.sim_seed, "draw": draw.as_dict(),
        "behaviour": draw.behaviour, "posture": draw.posture, "height_m": draw.height_m,
        "exit_code": exit_code, "wall_s": wall_s,
        "outcome": outcome, "reason": summary.get("reason", ""),
        "dropped": dropped, "final_holder": holder,
        "success": outcome == "released" and holder == "receiver" and not dropped,
        **{k: _finite_or_none(v) for k, v in _times(rec).items()},
        "transfer_point_base_m": point,
        "djt_optimum_base_m": None if djt_optimum_base_m is None else [float(v) for v in djt_optimum_base_m],
        "transfer_point_error_m": error,
        **near,
        "peak_grip_force_n": peak_grip,
        "force_overshoot_n": summary.get("force_overshoot_n"),
        "release_to_rest_s": summary.get("release_to_stop_s") if outcome == "released" else None,
        "protective_stops": [reason for reason, protective in stops if protective],
        "faults": summary.get("faults", []),
        "replans": summary.get("replans"),
        "phase_durations_s": summary.get("phase_durations_s", {}),
        "criteria": _criteria(rec, draw, dropped, peak_grip, near["peak_speed_near_hand_m_s"]),
    }
