"""Clairvoyant bound: the best outcome ANY admissible grip-force sequence can reach in an episode.

The contact plant (`robot_sim.contact`) is deterministic given the episode: the ground truth
(object, pads, receiver) does not depend on the sensor noise, and the only input is the grip
command, which the gripper's position loop latches once per loop period (25 Hz by default: a
command can change only at those latches). An *admissible* law is therefore a sequence of
commands c[0..L-1] in [0, F_max], one per latch, with the actuator's own rate limit and lag
applied by the plant. A *clairvoyant* law knows the episode (mass, μ, the receiver's intent and
its future pull) and may pick any such sequence.

Objective, lexicographic: (1) no drop; (2) taking receivers: handed over (released, not dropped,
the receiver holds it); other receivers: kept; (3) the lowest force overshoot.

Method (a 1-D exhaustive search over latch indices, vectorised over candidates):

1. **Stuck load.** One run with the largest grip from t = 0 (`F_max`, the max-hold). While the
   object sticks it does not move, so the receiver's hand and the external force on the object
   F_ext = F_hand + (0, M g) do not depend on the grip at all: that run gives, for every latch
   period j, the least grip that keeps the object stuck, need[j] = max |F_ext| / μ_s over the
   period. The same run is the "keep" candidate (it never lets go).
2. **Envelope family.** For a release latch k: c[j] = min(F_max, m · max(need[j..k-1])) for
   j < k, and 0 from k on. The command is non-increasing before k, and the finger only lags
   *above* a falling command, so the grip stays ≥ m · need: the object is held exactly where
   the receiver's hand expects it until k, with the least grip that does so (margin m = 1.01),
   and from k the grip falls as fast as the actuator allows. Every latch k of the episode is
   tried (taking receivers), plus "never release".
3. **Falsification search.** Where the best of the family fails (a drop, or a taking episode
   not handed over), `search` random admissible sequences outside the family (piecewise
   constant, 1–3 levels, log-uniform in [0.5 N, F_max], random switch latches, half of them
   ending at 0 N) are tried as well; the best of all is kept and its source recorded.

Tolerance: the release time is exact on the actuator's latch grid (there is no finer choice);
the hold is within the margin (1 %) of the exact least holding grip. Outside the family the
bound is a search, not a proof: docs/gripper.md ("Oracle bound") gives the argument and the
counts.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, is_dataclass, replace

import numpy as np

from handover_model.grip import SensorSample
from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.episode import run_vectorised
from robot_sim.contact.outcome import BatchOutcome, OutcomeAccumulator
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import Behaviour, ReceiverParams

__all__ = ["CommandTable", "ClairvoyantResult", "clairvoyant_bound", "envelope_commands", "latch_grid",
           "stuck_load", "subset_episodes"]

#: Source of an episode's best sequence.
FAMILY, SEARCH = 0, 1
#: Candidates simulated in one vectorised run (bounds memory: the plant keeps blocks of (128, n) arrays).
MAX_BATCH = 4000


def latch_grid(config: SimConfig) -> tuple[int, int, float]:
    """(plant steps per latch, latches per episode, latch period in s) of the gripper's position loop."""
    rate = np.asarray(config.gripper.loop_rate_hz, dtype=float)
    if rate.ndim:
        raise ContactSimError("the clairvoyant bound needs one gripper loop rate per run (chunk)")
    every = config.every(float(rate))
    return every, (config.n_steps - 1) // every + 1, every * config.dt_s


class CommandTable:
    """Replays a precomputed command per latch: row i is episode i's sequence (N).

    A `GripController` stepped at the latch period; the command returned at time t is the
    one the position loop latches at t (`robot_sim.contact.episode.run_vectorised`)."""

    def __init__(self, table_n: np.ndarray, period_s: float) -> None:
        self.table_n = np.asarray(table_n, dtype=float)
        if self.table_n.ndim != 2 or not np.all(np.isfinite(self.table_n)) or np.any(self.table_n < 0):
            raise ContactSimError("a command table is a finite, non-negative (episodes, latches) array")
        self.period_s = float(period_s)

    def reset(self, n_episodes: int = 1) -> None:
        if n_episodes != self.table_n.shape[0]:
            raise ContactSimError(f"command table of {self.table_n.shape[0]} rows run on {n_episodes} episodes")

    def step(self, sample: SensorSample) -> np.ndarray:
        j = min(int(round(sample.time_s / self.period_s)), self.table_n.shape[1] - 1)
        return self.table_n[:, j].copy()


def _index(obj, idx: np.ndarray, n: int):
    """`obj` (a parameter dataclass) with every per-episode array field (shape (n,)) indexed."""
    changes = {}
    for f in fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray) and v.shape == (n,):
            changes[f.name] = v[idx]
        elif is_dataclass(v) and not isinstance(v, type):
            changes[f.name] = _index(v, idx, n)
    return replace(obj, **changes) if changes else obj


def subset_episodes(config: SimConfig, receivers: ReceiverParams, idx) -> tuple[SimConfig, ReceiverParams]:
    """The episodes `idx` (indices, repeats allowed) of a stacked run: config and receivers."""
    n = receivers.n_episodes
    idx = np.asarray(idx, dtype=np.int64)
    rec = ReceiverParams(**{f.name: np.asarray(getattr(receivers, f.name))[idx] for f in fields(receivers)})
    return _index(config, idx, n), rec


def _per_episode(value, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()


def stuck_load(config: SimConfig, receivers: ReceiverParams) -> tuple[np.ndarray, BatchOutcome]:
    """Least grip that keeps each episode's object stuck, per latch period (N, shape (n, L)),
    from the max-hold run, and that run's outcome (see the module docstring, step 1)."""
    n = receivers.n_episodes
    every, n_latch, _ = latch_grid(config)
    f_max = _per_episode(config.gripper.max_force_n, n)
    weight, mu_s = _per_episode(config.obj.weight_n, n), _per_episode(config.obj.mu_static, n)
    plant = ContactPlant(config, receivers, seed=0, initial_grip_force_n=f_max)
    acc = OutcomeAccumulator(n, config.drop_distance_m)
    need = np.zeros((n, n_latch))

    def record() -> None:
        acc.update(plant.time_s, plant.mode, plant.pull_x, plant.pull_y, plant.px, plant.py, plant.ay, plant.holds)

    record()
    for k in range(1, config.n_steps + 1):
        plant.step(f_max)  # the forces of step k - 1 (latch period (k - 1) // every)
        j = (k - 1) // every
        need[:, j] = np.maximum(need[:, j], np.hypot(plant.pull_x, plant.pull_y + weight) / mu_s)
        if k % config.record_every == 0:
            record()
    return need, acc.result()


def envelope_commands(need_n: np.ndarray, release_latch: np.ndarray, margin: float, max_force_n) -> np.ndarray:
    """Envelope sequences (N, shape (m, L)): m · max(need[j..k-1]) before the release latch k,
    0 from k on (k = L: never released), clipped to the actuator's largest force."""
    need_n = np.asarray(need_n, dtype=float)
    k = np.asarray(release_latch, dtype=np.int64)[:, None]
    j = np.arange(need_n.shape[1])[None, :]
    before = j < k
    tail_max = np.maximum.accumulate(np.where(before, need_n, 0.0)[:, ::-1], axis=1)[:, ::-1]
    cap = np.broadcast_to(np.asarray(max_force_n, dtype=float), (need_n.shape[0],))[:, None]
    return np.where(before, np.minimum(margin * tail_max, cap), 0.0)


def _run_tables(config: SimConfig, receivers: ReceiverParams, episode: np.ndarray, tables: np.ndarray
                ) -> BatchOutcome:
    """Outcome of command table row r on episode `episode[r]` (in batches of `MAX_BATCH`)."""
    _, _, period = latch_grid(config)
    parts = []
    for lo in range(0, len(episode), MAX_BATCH):
        sel = slice(lo, lo + MAX_BATCH)
        cfg, rec = subset_episodes(config, receivers, episode[sel])
        parts.append(run_vectorised(cfg, rec, CommandTable(tables[sel], period), seed=0))
    return BatchOutcome.concatenate(parts)


def _score(out: BatchOutcome, taking: np.ndarray) -> np.ndarray:
    """Lexicographic objective as one number (lower is better): drop, then not handed over
    (taking receivers), then the force overshoot (N, < 1e4)."""
    fail = np.asarray(taking, dtype=bool) & ~out.handed_over
    over = np.nan_to_num(out.force_overshoot_n, nan=0.0)
    return 2e4 * out.dropped + 1e4 * fail + np.minimum(over, 9999.0)


@dataclass(frozen=True)
class ClairvoyantResult:
    """The clairvoyant bound of n episodes (arrays of shape (n,)).

    Attributes:
        success: handed over (taking receivers) or kept (others) by the best sequence found.
        dropped: even the best sequence drops it: unavoidable for every sequence tried.
        handed_over: the best sequence hands it over.
        overshoot_n: force overshoot of the best sequence, N.
        release_latch: its release latch (-1: never released, or a searched sequence).
        source: `FAMILY` or `SEARCH` (a random sequence beat the family).
        max_hold_dropped: the max-hold run drops it.
        searched: episodes the falsification search ran on.
        release_window: release latches of the envelope family that succeed (taking
            receivers: how much timing slack a clairvoyant has; 0 where not tried).
    """

    success: np.ndarray
    dropped: np.ndarray
    handed_over: np.ndarray
    overshoot_n: np.ndarray
    release_latch: np.ndarray
    source: np.ndarray
    max_hold_dropped: np.ndarray
    searched: np.ndarray
    release_window: np.ndarray

    def __len__(self) -> int:
        return int(self.success.shape[0])

    @staticmethod
    def concatenate(parts: list["ClairvoyantResult"]) -> "ClairvoyantResult":
        return ClairvoyantResult(**{f.name: np.concatenate([getattr(p, f.name) for p in parts])
                                    for f in fields(ClairvoyantResult)})


def random_tables(rng: np.random.Generator, count: int, n_latch: int, max_force_n: float) -> np.ndarray:
    """`count` random admissible sequences (N, shape (count, L)): 1–3 constant levels,
    log-uniform in [0.5 N, max], random switch latches; half of them end at 0 N."""
    levels = np.exp(rng.uniform(np.log(0.5), np.log(max_force_n), (count, 3)))
    levels[:, 2] = np.where(rng.random(count) < 0.5, 0.0, levels[:, 2])
    cuts = np.sort(rng.integers(0, n_latch + 1, (count, 2)), axis=1)
    j = np.arange(n_latch)[None, :]
    seg = (j >= cuts[:, :1]).astype(int) + (j >= cuts[:, 1:]).astype(int)
    return np.take_along_axis(levels, seg, axis=1)


class _Best:
    """The best sequence found so far per episode (see `clairvoyant_bound`)."""

    def __init__(self, hold: BatchOutcome, taking: np.ndarray) -> None:
        self.taking = taking
        self.score = _score(hold, taking)
        self.dropped, self.handed_over = hold.dropped.copy(), hold.handed_over.copy()
        self.overshoot_n = hold.force_overshoot_n.copy()
        self.release_latch = np.full(len(hold), -1, dtype=np.int64)
        self.source = np.full(len(hold), FAMILY, dtype=np.int8)

    def offer(self, episodes: np.ndarray, per: int, out: BatchOutcome, release_latch: np.ndarray,
              source: int) -> None:
        """`per` candidates for each of `episodes` (rows grouped by episode, in order)."""
        if not len(episodes):
            return
        score = _score(out, np.repeat(self.taking[episodes], per)).reshape(len(episodes), per)
        pick = score.argmin(axis=1)
        rows = np.arange(len(episodes)) * per + pick
        better = score[np.arange(len(episodes)), pick] < self.score[episodes]
        e, r = episodes[better], rows[better]
        self.score[e] = score.ravel()[r]
        self.dropped[e], self.handed_over[e] = out.dropped[r], out.handed_over[r]
        self.overshoot_n[e], self.release_latch[e] = out.force_overshoot_n[r], release_latch[r]
        self.source[e] = source

    def failing(self) -> np.ndarray:
        return np.flatnonzero(self.dropped | (self.taking & ~self.handed_over))


def clairvoyant_bound(config: SimConfig, receivers: ReceiverParams, margin: float = 1.01, search: int = 64,
                      seed: int = 0) -> ClairvoyantResult:
    """The clairvoyant bound of every episode of a stacked run (module docstring: method).

    Args:
        config, receivers: the episodes (a benchmark chunk: `episodes.sample_chunk`).
        margin: hold margin m over the least holding grip (≥ 1).
        search: random sequences tried on each episode the family fails (0: none).
        seed: seed of that search.
    """
    if not margin >= 1.0:
        raise ContactSimError(f"the hold margin must be >= 1, got {margin}")
    n = receivers.n_episodes
    taking = np.atleast_1d(np.asarray(receivers.behaviour) == Behaviour.TAKING)
    need, hold = stuck_load(config, receivers)
    _, n_latch, _ = latch_grid(config)
    f_max = _per_episode(config.gripper.max_force_n, n)
    best = _Best(hold, taking)
    tried = np.flatnonzero(taking | hold.dropped)
    episode = np.repeat(tried, n_latch)
    latch = np.tile(np.arange(n_latch), len(tried))
    window = np.zeros(n, dtype=np.int64)
    if len(tried):
        out = _run_tables(config, receivers, episode, envelope_commands(need[episode], latch, margin, f_max[episode]))
        best.offer(tried, n_latch, out, latch, FAMILY)
        ok = ~out.dropped & (out.handed_over | ~taking[episode])
        window[tried] = ok.reshape(len(tried), n_latch).sum(axis=1)
    searched = np.zeros(n, dtype=bool)
    failing = best.failing()
    if search > 0 and len(failing):
        rng = np.random.default_rng(seed)
        episode = np.repeat(failing, search)
        tables = np.concatenate([random_tables(rng, search, n_latch, float(f_max[e])) for e in failing])
        out = _run_tables(config, receivers, episode, tables)
        best.offer(failing, search, out, np.full(len(episode), -1, dtype=np.int64), SEARCH)
        searched[failing] = True
    success = ~best.dropped & (best.handed_over | ~taking)
    return ClairvoyantResult(success=success, dropped=best.dropped.copy(), handed_over=best.handed_over.copy(),
                             overshoot_n=best.overshoot_n, release_latch=best.release_latch, source=best.source,
                             max_hold_dropped=hold.dropped.copy(), searched=searched, release_window=window)
