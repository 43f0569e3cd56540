"""Statistics of the closed-loop comparison of both plants (`mujoco_loop`), with the
benchmark's helpers wherever they exist:

- per controller and plant: `benchmark.controller_stats` (drop rate with its 95 % Wilson
  interval, release success among the taking receivers with its interval, overshoot median
  and p95 over all taking episodes, release time), plus 95 % bootstrap intervals of the
  overshoot median and p95 (`scipy.stats.bootstrap`, BCa, percentile where BCa is undefined);
- McNemar's exact test of paired drops (`benchmark.paired_drop_test`): our plant against
  MuJoCo for each controller, and each controller against SG within each plant;
- verdict flips: the episodes whose drop (or handover) verdict differs between the plants,
  per controller and receiver kind, with their indices (to replay one).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.stats import bootstrap

from services.studies.gripper.benchmark import BenchResult, ControllerStats, controller_stats, paired_drop_test
from services.studies.gripper.episodes import RECEIVER_KINDS
from services.studies.gripper.mujoco_loop import PLANTS, LoopResult

__all__ = ["PlantStats", "Flips", "plant_stats", "percentile_ci", "mcnemar_rows", "flips", "bench_view"]


def percentile_ci(values: np.ndarray, q: float, level: float = 0.95, n_resamples: int = 2000,
                  seed: int = 0) -> tuple[float, float]:
    """Bootstrap interval of the `q`-th percentile of `values` (BCa; percentile where BCa is
    undefined, e.g. many equal values); (nan, nan) for fewer than 2 values, (v, v) when all equal."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return (math.nan, math.nan)
    if np.ptp(x) == 0.0:
        return (float(x[0]), float(x[0]))
    low = high = math.nan
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = bootstrap((x,), lambda s, axis=-1: np.percentile(s, q, axis=axis), vectorized=True,
                            n_resamples=n_resamples, confidence_level=level, method=method,
                            random_state=np.random.default_rng(seed))
        low, high = (float(v) for v in res.confidence_interval)
        if math.isfinite(low) and math.isfinite(high):
            break
    return (low, high)


@dataclass(frozen=True)
class PlantStats:
    """One controller on one plant: the benchmark's figures and the overshoot intervals (N)."""

    plant: str
    stats: ControllerStats
    overshoot_median_ci: tuple[float, float]
    overshoot_p95_ci: tuple[float, float]


def bench_view(result: LoopResult) -> BenchResult:
    """The comparison as a `BenchResult` whose controllers are "NAME@PLANT", for the
    benchmark's statistics helpers."""
    d = result.draws
    outcomes = {f"{c}@{p}": per[p] for c, per in result.outcomes.items() for p in PLANTS}
    return BenchResult(outcomes=outcomes, mass_kg=d["mass_kg"], mu_static=d["mu"], pull_angle_rad=d["pull_angle_rad"],
                       behaviour=d["behaviour"], grasp_start_s=d["grasp_start_s"], seed=result.seed,
                       wall_time_s=sum(result.wall_s.values()), kind=d["kind"], population=result.population)


def plant_stats(result: LoopResult) -> list[PlantStats]:
    """Per controller (in run order), per plant (ours, then MuJoCo)."""
    d = result.draws
    take = d["behaviour"] == 0
    rows = []
    for c, per in result.outcomes.items():
        for p in PLANTS:
            s = controller_stats(c, per[p], d["behaviour"], d["grasp_start_s"])
            over = per[p].force_overshoot_n[take]
            rows.append(PlantStats(p, s, percentile_ci(over, 50.0), percentile_ci(over, 95.0)))
    return rows


def mcnemar_rows(result: LoopResult, against: str = "SG") -> list[dict]:
    """McNemar exact tests: for each controller our plant against MuJoCo ("ours-only drops"
    and "MuJoCo-only drops"); then within each plant each controller against `against` (if run)."""
    view = bench_view(result)
    rows = []
    for c in result.outcomes:
        t = paired_drop_test(view, f"{c}@ours", f"{c}@mujoco")
        rows.append({"test": "ours vs MuJoCo", "controller": c, "a": "ours", "b": "MuJoCo",
                     "only_a_drops": t["only_a_drops"], "only_b_drops": t["only_b_drops"], "p_value": t["p_value"]})
    if against in result.outcomes:
        for p in PLANTS:
            for c in result.outcomes:
                if c != against:
                    t = paired_drop_test(view, f"{c}@{p}", f"{against}@{p}")
                    rows.append({"test": f"vs {against} on {'MuJoCo' if p == 'mujoco' else 'ours'}",
                                 "controller": c, "a": c, "b": against, "only_a_drops": t["only_a_drops"],
                                 "only_b_drops": t["only_b_drops"], "p_value": t["p_value"]})
    return rows


@dataclass(frozen=True)
class Flips:
    """Verdict disagreements of one controller over one receiver kind ("all": every kind).

    episodes: how many. ours_only_drops / mujoco_only_drops: indices of the episodes only that
    plant dropped. handover_flips: indices whose handed-over verdict differs."""

    controller: str
    kind: str
    episodes: int
    ours_only_drops: tuple[int, ...]
    mujoco_only_drops: tuple[int, ...]
    handover_flips: tuple[int, ...]

    @property
    def drop_flips(self) -> int:
        return len(self.ours_only_drops) + len(self.mujoco_only_drops)


def flips(result: LoopResult) -> list[Flips]:
    """Per controller: one row per receiver kind present (in `RECEIVER_KINDS` order), then "all"."""
    d = result.draws
    index = d["index"]
    rows = []
    for c, per in result.outcomes.items():
        ours, mj = per["ours"], per["mujoco"]
        masks = [(RECEIVER_KINDS[k], d["kind"] == k) for k in range(len(RECEIVER_KINDS)) if np.any(d["kind"] == k)]
        for label, m in masks + [("all", np.ones(index.size, dtype=bool))]:
            rows.append(Flips(c, label, int(m.sum()),
                              tuple(int(i) for i in index[m & ours.dropped & ~mj.dropped]),
                              tuple(int(i) for i in index[m & ~ours.dropped & mj.dropped]),
                              tuple(int(i) for i in index[m & (ours.handed_over != mj.handed_over)])))
    return rows
