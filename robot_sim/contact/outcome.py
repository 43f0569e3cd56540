"""Episode records and their outcome, computed from ground truth only.

These dataclasses are the shared currency of the realistic plant (`robot_sim.contact`) and
of the thesis model mode (`robot_sim.thesis_model`): both fill an `EpisodeTrace`, and
`outcome_from_trace` judges it the same way. A batch run never stores traces; it keeps an
`OutcomeAccumulator` that applies the same rules step by step (the tests check that both
give the same numbers).

Frame: gripper frame of the transfer loop, x toward the receiver, y DOWN (see
`handover_model.grip`). Positions are the object's displacement from where it was
first grasped, which is also its displacement relative to the pads (the gripper does not
move during the transfer phase in this simulator).

Outcome rules (all from ground truth, never from the sensors):
- released: the episode ends in RELEASE mode (the pads press no more on the object);
  `release_time_s` is the start of that final RELEASE stretch.
- dropped: at some time the object has moved more than `drop_distance_m` (default 10 cm)
  down from its start while the receiver does not hold it; `drop_time_s` is the first such
  time. With a 3 cm pad extent, that is an object that left the fingers and fell freely.
- handed over: released, not dropped, and the receiver holds it at the end.
- force overshoot: the largest magnitude of the receiver's force on the object before the
  release (over the whole episode if never released), N.
- slip distance: path length the object slides along the pads in SLIP mode, m.
- peak downward acceleration: largest true a_y over the episode, m/s² (g for a drop).
- mode timeline and the number of mode switches.
"""

from __future__ import annotations

from dataclasses import dataclass, field, asdict

import numpy as np

from handover_model.grip import GripController, Mode, SensorSample

__all__ = [
    "Mode",
    "SensorSample",
    "GripController",
    "EpisodeTrace",
    "EpisodeOutcome",
    "BatchOutcome",
    "OutcomeAccumulator",
    "outcome_from_trace",
    "DEFAULT_DROP_DISTANCE_M",
]

#: An unheld object that has moved this far down from its start counts as dropped (m).
DEFAULT_DROP_DISTANCE_M = 0.10


@dataclass
class EpisodeTrace:
    """Time series of one episode, all arrays of shape (T,), gripper frame (x to receiver, y down).

    Required:
        time_s: sample times (s), increasing.
        mode: `Mode` values (int8).
        grip_force_n: normal force the pads really apply (N).
        pull_force_x_n, pull_force_y_n: the receiver's total force on the object (N); in a
            thesis-model run this is F_p (cos φ, sin φ) minus the weight support if any.
        object_position_x_m, object_position_y_m: object displacement from its start (m).
        object_accel_y_m_s2: true downward acceleration of the object (m/s²).
        receiver_holds: True where the receiver's hand supports the object (bool).
    Optional (NaN-filled or None when a model has no such signal):
        grip_command_n: grip force commanded by the controller (N).
        object_velocity_x_m_s, object_velocity_y_m_s: true object velocity (m/s).
        object_accel_x_m_s2: true acceleration along x (m/s²).
        sensed_force_x_n, sensed_force_y_n: F/T sensor output F_sx, F_sy (N).
        accel_estimate_y_m_s2: a_y the controller saw (m/s²).
        optical_valid: optical sensor sees the object (bool).
        hand_position_x_m, hand_position_y_m: receiver hand position, same frame (m).
        receiver_grasp: receiver grasp level in [0, 1].
    """

    time_s: np.ndarray
    mode: np.ndarray
    grip_force_n: np.ndarray
    pull_force_x_n: np.ndarray
    pull_force_y_n: np.ndarray
    object_position_x_m: np.ndarray
    object_position_y_m: np.ndarray
    object_accel_y_m_s2: np.ndarray
    receiver_holds: np.ndarray
    grip_command_n: np.ndarray | None = None
    object_velocity_x_m_s: np.ndarray | None = None
    object_velocity_y_m_s: np.ndarray | None = None
    object_accel_x_m_s2: np.ndarray | None = None
    sensed_force_x_n: np.ndarray | None = None
    sensed_force_y_n: np.ndarray | None = None
    accel_estimate_y_m_s2: np.ndarray | None = None
    optical_valid: np.ndarray | None = None
    hand_position_x_m: np.ndarray | None = None
    hand_position_y_m: np.ndarray | None = None
    receiver_grasp: np.ndarray | None = None
    label: str = ""

    def __len__(self) -> int:
        return int(np.shape(self.time_s)[0])


@dataclass(frozen=True)
class EpisodeOutcome:
    """Judgement of one episode from ground truth (see the module docstring for the rules)."""

    released: bool
    release_time_s: float
    dropped: bool
    drop_time_s: float
    handed_over: bool
    force_overshoot_n: float
    slip_distance_m: float
    peak_down_accel_m_s2: float
    mode_switch_count: int
    mode_timeline: tuple[tuple[float, Mode], ...] = field(default_factory=tuple)

    def to_dict(self) -> dict:
        """Plain-Python dict (JSON-ready; modes as names, NaN kept as float)."""
        d = asdict(self)
        d["mode_timeline"] = [(t, Mode(m).name) for t, m in self.mode_timeline]
        return d


def outcome_from_trace(
    trace: EpisodeTrace, drop_distance_m: float = DEFAULT_DROP_DISTANCE_M
) -> EpisodeOutcome:
    """Judge one recorded episode (rules in the module docstring)."""
    t = np.asarray(trace.time_s, dtype=float)
    mode = np.asarray(trace.mode, dtype=np.int8)
    if t.ndim != 1 or t.size == 0 or mode.shape != t.shape:
        raise ValueError("trace.time_s and trace.mode must be 1-D arrays of the same, non-zero length")
    holds = np.asarray(trace.receiver_holds, dtype=bool)
    py = np.asarray(trace.object_position_y_m, dtype=float)
    px = np.asarray(trace.object_position_x_m, dtype=float)

    released = bool(mode[-1] == Mode.RELEASE)
    if released:
        not_release = np.flatnonzero(mode != Mode.RELEASE)
        first = 0 if not_release.size == 0 else int(not_release[-1]) + 1
        release_time_s = float(t[first])
        before = np.arange(t.size) < first
    else:
        release_time_s = float("nan")
        before = np.ones(t.size, dtype=bool)

    drop_idx = np.flatnonzero((py > drop_distance_m) & ~holds)
    dropped = bool(drop_idx.size)
    drop_time_s = float(t[drop_idx[0]]) if dropped else float("nan")

    pull = np.hypot(np.asarray(trace.pull_force_x_n, float), np.asarray(trace.pull_force_y_n, float))
    overshoot = float(pull[before].max()) if before.any() else 0.0

    step_len = np.hypot(np.diff(px), np.diff(py))
    slip_distance = float(step_len[mode[1:] == Mode.SLIP].sum())

    switches = np.flatnonzero(mode[1:] != mode[:-1]) + 1
    starts = np.concatenate(([0], switches))
    timeline = tuple((float(t[i]), Mode(int(mode[i]))) for i in starts)

    return EpisodeOutcome(
        released=released,
        release_time_s=release_time_s,
        dropped=dropped,
        drop_time_s=drop_time_s,
        handed_over=bool(released and not dropped and holds[-1]),
        force_overshoot_n=overshoot,
        slip_distance_m=slip_distance,
        peak_down_accel_m_s2=float(np.max(trace.object_accel_y_m_s2)),
        mode_switch_count=int(switches.size),
        mode_timeline=timeline,
    )


@dataclass
class BatchOutcome:
    """Outcomes of n episodes as arrays of shape (n,) (same meaning as `EpisodeOutcome`).

    `force_overshoot_n` here is the largest receiver force up to the *last* entry into
    RELEASE, which equals the trace rule.
    """

    released: np.ndarray
    release_time_s: np.ndarray
    dropped: np.ndarray
    drop_time_s: np.ndarray
    handed_over: np.ndarray
    force_overshoot_n: np.ndarray
    slip_distance_m: np.ndarray
    peak_down_accel_m_s2: np.ndarray
    mode_switch_count: np.ndarray
    final_mode: np.ndarray

    def __len__(self) -> int:
        return int(self.released.shape[0])

    def episode(self, i: int) -> EpisodeOutcome:
        """Outcome of episode i (without a mode timeline, which a batch does not keep)."""
        return EpisodeOutcome(
            released=bool(self.released[i]),
            release_time_s=float(self.release_time_s[i]),
            dropped=bool(self.dropped[i]),
            drop_time_s=float(self.drop_time_s[i]),
            handed_over=bool(self.handed_over[i]),
            force_overshoot_n=float(self.force_overshoot_n[i]),
            slip_distance_m=float(self.slip_distance_m[i]),
            peak_down_accel_m_s2=float(self.peak_down_accel_m_s2[i]),
            mode_switch_count=int(self.mode_switch_count[i]),
        )

    @staticmethod
    def concatenate(parts: list["BatchOutcome"]) -> "BatchOutcome":
        """Join batches in order."""
        names = BatchOutcome.__dataclass_fields__.keys()
        return BatchOutcome(**{k: np.concatenate([getattr(p, k) for p in parts]) for k in names})

    def summary(self) -> dict:
        """Rates and statistics over the batch (JSON-ready floats)."""
        n = len(self)
        rel = self.release_time_s[self.released]

        def pct(a: np.ndarray, q: float) -> float:
            return float(np.percentile(a, q)) if a.size else float("nan")

        return {
            "episodes": n,
            "handed_over_rate": float(self.handed_over.mean()) if n else float("nan"),
            "drop_rate": float(self.dropped.mean()) if n else float("nan"),
            "released_rate": float(self.released.mean()) if n else float("nan"),
            "release_time_median_s": pct(rel, 50),
            "force_overshoot_median_n": pct(self.force_overshoot_n, 50),
            "force_overshoot_p95_n": pct(self.force_overshoot_n, 95),
            "slip_distance_median_m": pct(self.slip_distance_m, 50),
            "peak_down_accel_median_m_s2": pct(self.peak_down_accel_m_s2, 50),
            "mode_switches_mean": float(self.mode_switch_count.mean()) if n else float("nan"),
        }


class OutcomeAccumulator:
    """Applies the `outcome_from_trace` rules online to n episodes stepped together.

    Call `update(...)` once per recorded sample with arrays of shape (n,), then `result()`.
    """

    def __init__(self, n_episodes: int, drop_distance_m: float = DEFAULT_DROP_DISTANCE_M):
        n = int(n_episodes)
        self.drop_distance_m = float(drop_distance_m)
        self._first = True
        self._mode = np.zeros(n, dtype=np.int8)
        self._px = np.zeros(n)
        self._py = np.zeros(n)
        self._release_start = np.full(n, np.nan)
        self._drop_time = np.full(n, np.nan)
        self._max_pull_running = np.zeros(n)
        self._overshoot = np.zeros(n)
        self._slip = np.zeros(n)
        self._peak_acc = np.full(n, -np.inf)
        self._switches = np.zeros(n, dtype=np.int64)
        self._holds = np.zeros(n, dtype=bool)

    def update(self, time_s, mode, pull_x_n, pull_y_n, pos_x_m, pos_y_m, accel_y_m_s2, receiver_holds):
        """Add one sample for all episodes (arrays of shape (n,); time_s a float)."""
        mode = np.asarray(mode, dtype=np.int8)
        pull = np.hypot(pull_x_n, pull_y_n)
        is_rel = mode == Mode.RELEASE
        if self._first:
            entered = is_rel
            self._first = False
        else:
            entered = is_rel & (self._mode != Mode.RELEASE)
            self._switches += mode != self._mode
            slipping = mode == Mode.SLIP
            step = np.hypot(pos_x_m - self._px, pos_y_m - self._py)
            self._slip += np.where(slipping, step, 0.0)
        # Largest pull strictly before the latest entry into RELEASE.
        self._overshoot = np.where(entered, self._max_pull_running, self._overshoot)
        self._release_start = np.where(entered, time_s, self._release_start)
        self._max_pull_running = np.maximum(self._max_pull_running, pull)
        newly_dropped = (pos_y_m > self.drop_distance_m) & ~receiver_holds & np.isnan(self._drop_time)
        self._drop_time = np.where(newly_dropped, time_s, self._drop_time)
        self._peak_acc = np.maximum(self._peak_acc, accel_y_m_s2)
        self._mode = mode
        self._px = np.array(pos_x_m, dtype=float, copy=True)
        self._py = np.array(pos_y_m, dtype=float, copy=True)
        self._holds = np.asarray(receiver_holds, dtype=bool).copy()

    def result(self) -> BatchOutcome:
        """Outcomes so far."""
        released = self._mode == Mode.RELEASE
        dropped = ~np.isnan(self._drop_time)
        return BatchOutcome(
            released=released,
            release_time_s=np.where(released, self._release_start, np.nan),
            dropped=dropped,
            drop_time_s=self._drop_time.copy(),
            handed_over=released & ~dropped & self._holds,
            force_overshoot_n=np.where(released, self._overshoot, self._max_pull_running),
            slip_distance_m=self._slip.copy(),
            peak_down_accel_m_s2=self._peak_acc.copy(),
            mode_switch_count=self._switches.copy(),
            final_mode=self._mode.copy(),
        )
