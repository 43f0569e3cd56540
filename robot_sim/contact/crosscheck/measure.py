"""What the cross-check measures on a run, the same way on both plants' time series.

Gripper frame (x toward the receiver, y DOWN), SI units; times in s from the start of the
scenario, distances reported in mm, forces in N.

- **slip onset**: the first sample where the object's speed relative to the pads exceeds
  `SLIP_SPEED_M_S` (1 mm/s). Our plant's stuck object has speed 0 exactly; MuJoCo's soft
  friction lets a stuck box creep (< 0.2 mm/s in these scenarios, see the docs), so a speed
  threshold, not "any motion", marks the onset in both. Past the onset a slide accelerates
  at (|F_ext| − μ F_G)/M; the threshold adds the same short delay on both plants.
- **left the pads**: the first sample beyond the pads' footprint (`Run.left`).
- **slide distance**: the object's displacement from its start when it leaves the pads, or
  at the end of the run if it never does (it was caught or never slid).
- **caught**: it slid, never left the pads and is at rest between pressing pads at the end.
- **dropped**: more than `DROP_DISTANCE_M` below its start while the receiver does not hold
  it (the rule of `robot_sim.contact.outcome`); handed over: not dropped, held at the end.
- **force overshoot**: the largest hand force on the object while it is between the pads.
- **in-pad gap**: the largest distance between the two plants' object positions while the
  object is between the pads in both (point by point in time).
"""

from __future__ import annotations

import math

import numpy as np

from robot_sim.contact.crosscheck.runs import Run
from robot_sim.contact.crosscheck.scenario import Scenario

__all__ = ["SLIP_SPEED_M_S", "DROP_DISTANCE_M", "measure", "in_pad_gap_mm", "onset_index"]

#: Speed relative to the pads above which the object counts as slipping (m/s).
SLIP_SPEED_M_S = 1e-3
#: Outcome rule: an unheld object this far below its start is dropped (m).
DROP_DISTANCE_M = 0.10
_NONE = math.nan


def _first(mask: np.ndarray) -> int | None:
    idx = np.flatnonzero(mask)
    return int(idx[0]) if idx.size else None


def onset_index(run: Run) -> int | None:
    """Index of the first sample where the object slips (speed > `SLIP_SPEED_M_S`)."""
    return _first(run.speed_m_s > SLIP_SPEED_M_S)


def _time(run: Run, i: int | None) -> float:
    return float(run.time_s[i]) if i is not None else _NONE


def _step_start_s(run: Run, i: int) -> float:
    """Time (s) at the start of the step that produced sample i (samples follow each step)."""
    return float(run.time_s[i] - run.time_s[0])


def measure(sc: Scenario, run: Run) -> dict[str, float | bool]:
    """The quantities of `sc.kind` measured on `run` (keys as in `compare.QUANTITIES`)."""
    onset = onset_index(run)
    left = _first(run.left)
    out: dict[str, float | bool] = {}
    if sc.kind == "onset":
        out["onset_pull_n"] = sc.pull_n_at(_step_start_s(run, onset)) if onset is not None else _NONE
        return out
    out["onset_time_s"] = _time(run, onset)
    if sc.kind == "slide":
        end = left if left is not None else len(run.time_s) - 1
        out["left"] = left is not None
        out["leave_time_s"] = _time(run, left)
        out["slide_distance_mm"] = 1e3 * float(math.hypot(run.x_m[end], run.y_m[end])) if onset is not None else 0.0
        out["caught"] = bool(onset is not None and left is None and run.speed_m_s[-1] <= SLIP_SPEED_M_S
                             and run.grip_force_n[-1] > 0.0)
        return out
    dropped = _first((run.y_m > DROP_DISTANCE_M) & ~run.holds)
    out["dropped"] = dropped is not None
    out["drop_time_s"] = _time(run, dropped)
    out["handed_over"] = bool(dropped is None and run.holds[-1])
    inside = ~run.left
    force = np.hypot(run.hand_force_x_n, run.hand_force_y_n)
    out["overshoot_n"] = float(force[inside].max()) if inside.any() else 0.0
    return out


def in_pad_gap_mm(ours: Run, theirs: Run) -> float:
    """Largest distance (mm) between the two runs' object positions at our samples' times
    (`theirs` interpolated onto them, so the plants may step differently) while the object is
    between the pads in both (0 if never)."""
    t = ours.time_s[ours.time_s <= theirs.time_s[-1]]
    x, y = np.interp(t, theirs.time_s, theirs.x_m), np.interp(t, theirs.time_s, theirs.y_m)
    their_left = np.interp(t, theirs.time_s, theirs.left.astype(float)) > 0.0
    both = ~(ours.left[:t.size] | their_left)
    if not both.any():
        return 0.0
    gap = np.hypot(ours.x_m[:t.size] - x, ours.y_m[:t.size] - y)
    return 1e3 * float(gap[both].max())
