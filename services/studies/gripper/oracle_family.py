"""Sensor-only bound: the best law of ONE declared family that sees only the sensors.

The family (`ShareReleaseLaw`, four parameters, the same for every episode it runs on):

    W0  = F_sy of the first sample (the weight as the wrist feels it), |F| = hypot(F_sx, F_sy)
    F_G = clip(max(c_hold · W0, k_follow · |F|), 0, F_max)     until the release
    release (F_G = 0 from then on) once F_sy ≤ s_rel · W0 has held for τ without a break

In words: hold a grip scaled by the measured weight, raise it with the measured load, and let
go once the receiver has carried all but s_rel of the weight for τ (a bump or a tug that
unloads the gripper for less than τ does not open it). It sees the wrist F/T only, through the
same 100 Hz sensor with noise and bias as every controller, runs at 100 Hz, and drives the same
actuator (25 Hz loop, 50 N/s, [0, 140] N).

"Best" = the lowest value of the objective J on the tuning episodes:

    J = failure rate + 1e-4 / N × mean force overshoot of the handed-over taking episodes

with failure = dropped, or (taking receiver) not handed over: first no drop and the handover,
then the lowest overshoot (1e-4 per N is below one failure in 500 episodes for overshoots
under 20 N). Parameters are chosen globally (one law for all episodes: a real sensor-only
law), globally under an overshoot cap (J + 0.05 per N of p95 overshoot over all taking
episodes above HI's p95 on the same tuning episodes: the bound for a law that must not pull
harder than HI), or per behaviour class (the law is told the class: a bound for a perfect
intent classifier with this family), never per episode. The optimiser is
`scipy.optimize.differential_evolution` over `BOUNDS`, on the benchmark's tuning seed; the
result is evaluated on other seeds (`handover-study bench`). It is a bound over this family
only: a law outside it may do better.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
from scipy import optimize

from handover_model.grip import SensorSample
from robot_sim.contact.episode import run_vectorised
from services.gripper.errors import GripperError
from services.studies.gripper.episodes import BEHAVIOUR_NAMES, ChunkSpec, EpisodeDistribution
from services.studies.gripper.oracle import subset_episodes
from services.studies.gripper.populations import DEFAULT_POPULATION, draw_planned_chunk, plan_chunks, population

__all__ = ["BOUNDS", "FamilyParams", "ShareReleaseLaw", "TunedFamily", "bench_chunk", "bench_chunks",
           "draw_planned_chunk", "evaluate", "tune"]

#: Search box of the parameters (c_hold 1/μ-like, k_follow N/N, s_rel share, τ s). It holds the
#: max-hold (c_hold · W0 ≥ 140 N for every benchmark object, τ longer than an episode: never let go).
BOUNDS = {"hold_per_weight": (1.0, 300.0), "follow_gain": (0.0, 5.0), "release_share": (0.05, 0.95),
          "confirm_s": (0.01, 3.5)}
#: Parameters the optimiser searches on a log scale (they span two decades or more).
LOG_SCALED = ("hold_per_weight", "confirm_s")
#: Weight of the mean overshoot (per N) in the objective J.
OVERSHOOT_WEIGHT_PER_N = 1e-4
#: Penalty per N of p95 overshoot above the cap, for the capped member (5 failure points per N).
CAP_PENALTY_PER_N = 0.05
#: Where `handover-study oracle-tune` writes the tuned parameters and the benchmark reads them.
PARAMS_PATH = Path(__file__).with_name("oracle_family_params.json")


@dataclass(frozen=True)
class FamilyParams:
    """One member of the family (module docstring): c_hold (dimensionless), k_follow (N of grip
    per N of measured load), s_rel (share of the rest weight, in (0, 1)), τ (s)."""

    hold_per_weight: float
    follow_gain: float
    release_share: float
    confirm_s: float

    def __post_init__(self) -> None:
        for f in fields(self):
            lo, hi = BOUNDS[f.name]
            v = getattr(self, f.name)
            if not (np.isfinite(v) and lo <= v <= hi):
                raise GripperError(f"family parameter {f.name} = {v} is outside its box [{lo}, {hi}]")

    def as_array(self) -> np.ndarray:
        return np.array([getattr(self, f.name) for f in fields(self)], dtype=float)

    def search_point(self) -> np.ndarray:
        """The optimiser's coordinates of this member (log of the `LOG_SCALED` parameters)."""
        return np.array([np.log(getattr(self, f.name)) if f.name in LOG_SCALED else getattr(self, f.name)
                         for f in fields(self)])

    @staticmethod
    def from_array(x) -> "FamilyParams":
        names = [f.name for f in fields(FamilyParams)]
        return FamilyParams(**{k: float(np.clip(v, *BOUNDS[k])) for k, v in zip(names, np.ravel(x))})

    @staticmethod
    def from_search(x) -> "FamilyParams":
        """The member at the optimiser's coordinates `x` (see `search_point`)."""
        return FamilyParams.from_array(_natural(np.ravel(x)[:, None])[:, 0])


def _natural(x: np.ndarray) -> np.ndarray:
    """Optimiser coordinates (4, S) → natural parameters (4, S)."""
    out = np.array(x, dtype=float)
    for i, f in enumerate(fields(FamilyParams)):
        if f.name in LOG_SCALED:
            out[i] = np.exp(out[i])
    return out


def _search_bounds() -> list[tuple[float, float]]:
    return [tuple(np.log(BOUNDS[f.name])) if f.name in LOG_SCALED else BOUNDS[f.name]
            for f in fields(FamilyParams)]


class ShareReleaseLaw:
    """The family's law (module docstring), vectorised; every parameter a scalar or an array
    of shape (n,) (one member per episode, so that many members run in one batch)."""

    def __init__(self, hold_per_weight, follow_gain, release_share, confirm_s, max_grip_force_n: float = 140.0,
                 period_s: float = 0.01) -> None:
        self._p = [np.asarray(v, dtype=float) for v in (hold_per_weight, follow_gain, release_share, confirm_s)]
        self.max_grip_force_n, self.period_s = float(max_grip_force_n), float(period_s)

    @staticmethod
    def of(params: FamilyParams, period_s: float = 0.01) -> "ShareReleaseLaw":
        return ShareReleaseLaw(params.hold_per_weight, params.follow_gain, params.release_share, params.confirm_s,
                               period_s=period_s)

    def reset(self, n_episodes: int = 1) -> None:
        self.n = int(n_episodes)
        self.c_hold, self.k_follow, self.s_rel, self.tau = (np.broadcast_to(v, (self.n,)) for v in self._p)
        self.weight0: np.ndarray | None = None
        self.unloaded_s = np.zeros(self.n)
        self.released = np.zeros(self.n, dtype=bool)

    def step(self, sample: SensorSample) -> np.ndarray:
        fx = np.broadcast_to(np.asarray(sample.force_x_n, dtype=float), (self.n,))
        fy = np.broadcast_to(np.asarray(sample.force_y_n, dtype=float), (self.n,))
        if self.weight0 is None:
            self.weight0 = np.maximum(fy, 1e-3)
        else:
            unloaded = fy <= self.s_rel * self.weight0
            self.unloaded_s = np.where(unloaded, self.unloaded_s + self.period_s, 0.0)
            self.released |= self.unloaded_s >= self.tau - 1e-9
        demand = np.maximum(self.c_hold * self.weight0, self.k_follow * np.hypot(fx, fy))
        return np.where(self.released, 0.0, np.clip(demand, 0.0, self.max_grip_force_n))


def bench_chunks(seed: int, n_episodes: int, chunk_size: int,
                 dist: EpisodeDistribution | str | None = None) -> list[tuple[ChunkSpec, np.random.SeedSequence]]:
    """The chunks of a `handover-study bench` run of `dist` (a distribution or a population's
    name; default the bench's) and their sensor-noise seeds, drawn exactly as
    `benchmark.run_benchmark` draws them (`oracle_report` checks the draws against the run)."""
    dist = _distribution(dist)
    return [draw_planned_chunk(dist, plan) for plan in plan_chunks(dist, n_episodes, chunk_size, seed)]


def bench_chunk(seed: int, n_episodes: int, chunk_size: int, index: int,
                dist: EpisodeDistribution | str | None = None) -> tuple[ChunkSpec, np.random.SeedSequence]:
    """Chunk `index` of `bench_chunks` (only that chunk is drawn)."""
    dist = _distribution(dist)
    return draw_planned_chunk(dist, plan_chunks(dist, n_episodes, chunk_size, seed)[index])


def _distribution(dist: EpisodeDistribution | str | None) -> EpisodeDistribution:
    if isinstance(dist, EpisodeDistribution):
        return dist
    return population(DEFAULT_POPULATION if dist is None else dist)


def taking_overshoot_p95_n(overshoot_n: np.ndarray) -> np.ndarray:
    """Per row of `overshoot_n` (N; NaN in the columns of episodes that are not a take), the p95
    over the taking episodes, N (zeros when there is none): the benchmark table's p95."""
    take = np.isfinite(overshoot_n[0])
    return np.percentile(overshoot_n[:, take], 95, axis=1) if take.any() else np.zeros(len(overshoot_n))


@dataclass(frozen=True)
class Scores:
    """Per member (rows) and episode (columns): failed, dropped, handed over, and the force
    overshoot (N) of the taking episodes (NaN for the others)."""

    failed: np.ndarray
    dropped: np.ndarray
    handed_over: np.ndarray
    overshoot_n: np.ndarray

    def overshoot_p95_n(self) -> np.ndarray:
        """p95 of the overshoot over all taking episodes per member (the benchmark table's), N."""
        return taking_overshoot_p95_n(self.overshoot_n)

    def objective(self, overshoot_cap_n: float | None = None) -> np.ndarray:
        """J per member (module docstring); with a cap, plus `CAP_PENALTY_PER_N` per N of p95
        overshoot above it."""
        over = np.where(self.handed_over, self.overshoot_n, np.nan)
        counted = np.isfinite(over).sum(axis=1)
        mean_over = np.where(counted > 0, np.nansum(over, axis=1) / np.maximum(counted, 1), 0.0)
        j = self.failed.mean(axis=1) + OVERSHOOT_WEIGHT_PER_N * mean_over
        if overshoot_cap_n is not None:
            j = j + CAP_PENALTY_PER_N * np.maximum(self.overshoot_p95_n() - overshoot_cap_n, 0.0)
        return j


def evaluate(chunks: list[tuple[ChunkSpec, np.random.SeedSequence]], members: np.ndarray,
             behaviour: int | None = None) -> Scores:
    """Run every member (rows of `members`, shape (S, 4)) on the episodes of `chunks` (only
    those of one behaviour code if given), all members in one batch per chunk."""
    members = np.atleast_2d(np.asarray(members, dtype=float))
    s = members.shape[0]
    failed, dropped, handed, over = [], [], [], []
    for chunk, noise in chunks:
        keep = np.flatnonzero(chunk.behaviour == behaviour) if behaviour is not None else np.arange(
            chunk.behaviour.size)
        if not keep.size:
            continue
        cfg, rec = subset_episodes(chunk.config, chunk.receivers, np.tile(keep, s))
        law = ShareReleaseLaw(*np.repeat(members, keep.size, axis=0).T)
        out = run_vectorised(cfg, rec, law, seed=noise)
        take = np.tile(chunk.behaviour[keep] == 0, s)
        fail = out.dropped | (take & ~out.handed_over)
        failed.append(fail.reshape(s, -1))
        dropped.append(out.dropped.reshape(s, -1))
        handed.append((take & out.handed_over).reshape(s, -1))
        over.append(np.where(take, out.force_overshoot_n, np.nan).reshape(s, -1))
    if not failed:
        raise GripperError("no tuning episode of that behaviour")
    return Scores(*(np.concatenate(a, 1) for a in (failed, dropped, handed, over)))


def tune(chunks: list[tuple[ChunkSpec, np.random.SeedSequence]], behaviour: int | None = None,
         popsize: int = 4, maxiter: int = 12, seed: int = 0,
         overshoot_cap_n: float | None = None) -> tuple[FamilyParams, dict]:
    """The member with the lowest J on `chunks` (`scipy.optimize.differential_evolution` over
    `BOUNDS`, c_hold and τ on a log scale: `popsize` × 4 members per generation, `maxiter`
    generations, no early stop (tol = 0), no polish; the whole population runs in one batch per
    chunk). With `overshoot_cap_n`, J is penalised above that p95 overshoot. Returns the member and
    a summary."""
    evaluations = [0]

    def objective(x: np.ndarray) -> np.ndarray:
        evaluations[0] += x.shape[1]
        return evaluate(chunks, _natural(x).T, behaviour).objective(overshoot_cap_n)

    res = optimize.differential_evolution(objective, _search_bounds(), popsize=popsize, maxiter=maxiter, tol=0.0,
                                          polish=False, seed=seed, vectorized=True, updating="deferred")
    best = FamilyParams.from_search(res.x)
    scores = evaluate(chunks, best.as_array()[None, :], behaviour)
    summary = {"objective": float(res.fun), "failure_rate": float(scores.failed.mean()),
               "drop_rate": float(scores.dropped.mean()), "episodes": int(scores.failed.shape[1]),
               "overshoot_p95_n": float(scores.overshoot_p95_n()[0]), "overshoot_cap_n": overshoot_cap_n,
               "evaluations": evaluations[0], "generations": int(res.nit)}
    return best, summary


@dataclass(frozen=True)
class TunedFamily:
    """Tuned members: one global, one global under the overshoot cap, one per behaviour class,
    and how they were tuned."""

    global_params: FamilyParams
    capped: FamilyParams
    per_class: dict[str, FamilyParams]
    provenance: dict

    def class_members(self, behaviour: np.ndarray) -> np.ndarray:
        """Per-episode members (shape (n, 4)) chosen by the episode's behaviour code."""
        rows = [self.per_class[BEHAVIOUR_NAMES[int(b)]].as_array() for b in np.asarray(behaviour)]
        return np.array(rows).reshape(-1, 4)

    def save(self, path: Path = PARAMS_PATH) -> Path:
        doc = {"global": asdict(self.global_params), "global_capped": asdict(self.capped),
               "per_class": {k: asdict(v) for k, v in self.per_class.items()}, "provenance": self.provenance}
        path.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
        return path

    @staticmethod
    def load(path: Path = PARAMS_PATH) -> "TunedFamily":
        try:
            doc = json.loads(Path(path).read_text())
            per_class = {k: FamilyParams(**v) for k, v in doc["per_class"].items()}
            tuned = TunedFamily(FamilyParams(**doc["global"]), FamilyParams(**doc["global_capped"]), per_class,
                                doc.get("provenance", {}))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise GripperError(f"cannot read the tuned family parameters from {path}: {exc} "
                               "(run `handover-study oracle-tune`)") from exc
        missing = set(BEHAVIOUR_NAMES.values()) - set(per_class)
        if missing:
            raise GripperError(f"{path}: no tuned parameters for {sorted(missing)} (run `handover-study oracle-tune`)")
        return tuned
