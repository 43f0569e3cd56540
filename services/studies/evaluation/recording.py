"""What one episode's Rerun recording says, read back (`services.recorder.readback`).

Every figure of an episode record comes from here: the supervisor's episode summary, the
simulation's truth (`sim/truth`: object, receiver's hand, tool, who holds the object), the
gripper's release event, the motion goals, statuses and stops, the supervisor's states. Times
are the senders' stamps (ns since the epoch, one host clock); positions are `base`, m.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from services.recorder.errors import RecorderError
from services.recorder.readback import read_component
from services.studies.evaluation.errors import EvaluationError

_SUMMARY_FIELDS = ("source", "episode_id", "outcome", "reason", "transfer_point_base_m", "receiver_posture",
                   "phase_durations_s", "peak_grip_force_n", "force_overshoot_n", "release_to_stop_s", "replans",
                   "faults")


@dataclass
class Truth:
    """`sim/truth` rows, aligned: times (s since the epoch), tool and hand (N, 3) m, tool speed
    (N,) m/s, object (N, 3) m, slip (N,) m, dropped (N,) bool, held_by (N,) str."""

    t_s: np.ndarray
    tool_m: np.ndarray
    hand_m: np.ndarray
    tool_speed_m_s: np.ndarray
    object_m: np.ndarray
    slip_m: np.ndarray
    dropped: np.ndarray
    held_by: np.ndarray


@dataclass
class EpisodeRecording:
    """The parts of a recording an episode record is made of."""

    summary: dict[str, Any] | None
    truth: Truth
    release_s: float | None
    states: list[tuple[float, int, str]]
    goals: list[tuple[float, str, str]]
    statuses: list[tuple[float, str, str, str]]
    stops: list[tuple[float, str, bool]] = field(default_factory=list)


def _rows(path: Path, entity: str, component: str) -> list[tuple[int, Any]]:
    return read_component(path, entity, component)


def _column(path: Path, entity: str, name: str) -> list[Any]:
    return [v for _t, v in _rows(path, entity, name)]


def _scalar(value: Any) -> Any:
    """A one-value component as stored (a one-element list per row) → the value."""
    return value[0] if isinstance(value, list) and len(value) == 1 else value


def _summary(path: Path) -> dict[str, Any] | None:
    """The supervisor's first episode summary (None when there is none). Columns are matched
    by their row's stamp: a field that is None (no transfer point) has no row."""
    entity = "/bus/supervisor/episode"
    columns = {name: dict(_rows(path, entity, f"EpisodeSummary:{name}")) for name in _SUMMARY_FIELDS}
    for stamp in sorted(columns["outcome"]):
        if _scalar(columns["source"].get(stamp)) != "supervisor":
            continue
        row = {name: _scalar(values.get(stamp)) for name, values in columns.items()}
        point = columns["transfer_point_base_m"].get(stamp)
        row["transfer_point_base_m"] = None if point is None else [float(v) for v in point]
        row["faults"] = [str(f) for f in columns["faults"].get(stamp) or []]
        durations = columns["phase_durations_s"].get(stamp) or [[]]
        row["phase_durations_s"] = {str(k): float(v) for k, v in durations[0]}
        row["stamp_s"] = stamp * 1e-9
        return row
    return None


def _truth(path: Path) -> Truth:
    entity = "/bus/sim/truth"
    times = np.array([t for t, _ in _rows(path, entity, "SimTruth:tool_position_m")], dtype=np.int64)

    def vectors(name: str) -> np.ndarray:
        values = _column(path, entity, f"SimTruth:{name}")
        return np.asarray(values, dtype=float).reshape(-1, 3) if values else np.zeros((0, 3))

    def scalars(name: str, dtype: type = float) -> np.ndarray:
        return np.asarray([_scalar(v) for v in _column(path, entity, f"SimTruth:{name}")], dtype=dtype)

    truth = Truth(times * 1e-9, vectors("tool_position_m"), vectors("receiver_hand_position_m"),
                  scalars("tool_speed_m_s"), vectors("object_position_m"), scalars("slip_m"),
                  scalars("dropped", bool), scalars("held_by", object))
    lengths = {len(a) for a in (truth.t_s, truth.tool_m, truth.hand_m, truth.tool_speed_m_s, truth.object_m,
                                truth.slip_m, truth.dropped, truth.held_by)}
    if len(lengths) != 1:
        raise EvaluationError(f"{path}: the sim/truth columns have different lengths {sorted(lengths)}")
    return truth


def read_episode_recording(path: Path) -> EpisodeRecording:
    """Read what an episode record needs from the recording at `path`.

    Raises:
        EvaluationError: the recording is missing or unreadable (names the file).
    """
    try:
        summary = _summary(path)
        truth = _truth(path)
        releases = _rows(path, "/bus/gripper/release", "ReleaseEvent:grip_force_n")
        state_rows = _rows(path, "/bus/supervisor/state", "SupervisorState:phase")
        episode_ids = _column(path, "/bus/supervisor/state", "SupervisorState:episode_id")
        goal_rows = _rows(path, "/bus/motion/goal", "MotionGoal:goal_id")
        kinds = _column(path, "/bus/motion/goal", "MotionGoal:kind")
        status_rows = _rows(path, "/bus/motion/status", "MotionStatus:goal_id")
        status_states = _column(path, "/bus/motion/status", "MotionStatus:state")
        status_reasons = _column(path, "/bus/motion/status", "MotionStatus:reason")
        stop_rows = _rows(path, "/bus/motion/stop", "MotionStop:reason")
        protective = _column(path, "/bus/motion/stop", "MotionStop:protective")
    except RecorderError as exc:
        raise EvaluationError(f"cannot read the episode's recording: {exc}") from None
    return EpisodeRecording(
        summary=summary, truth=truth,
        release_s=releases[0][0] * 1e-9 if releases else None,
        states=[(t * 1e-9, int(_scalar(e)), str(_scalar(p)))
                for (t, p), e in zip(state_rows, episode_ids, strict=True)],
        goals=[(t * 1e-9, str(_scalar(g)), str(_scalar(k))) for (t, g), k in zip(goal_rows, kinds, strict=True)],
        statuses=[(t * 1e-9, str(_scalar(g)), str(_scalar(s)), str(_scalar(r)))
                  for (t, g), s, r in zip(status_rows, status_states, status_reasons, strict=True)],
        stops=[(t * 1e-9, str(_scalar(r)), bool(_scalar(p))) for (t, r), p in zip(stop_rows, protective, strict=True)],
    )
