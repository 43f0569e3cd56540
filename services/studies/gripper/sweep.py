"""Grid sweeps of a release controller's parameters on the benchmark's episodes, on the studies'
engine (`handover-study sweep`; the grid: `sweep_grid`; the reports: `sweep_report`).

Every grid point runs the SAME episodes (common random numbers): the chunks of a
`handover-study bench` run of the same seed, population, episode count and chunk size, each
with its own sensor-noise seed, and each (grid point × chunk) runs alone in its own batch, so a
grid point's figures are exactly those `handover-study bench --set CONTROLLER:NAME=VALUE` gives
on those episodes, and two grid points differ only by the parameters. Reference controllers
(HI, and the controller itself with its own parameters) run on the same episodes too.

The (point × chunk) tasks go through `services.studies.engine.run_tasks` (a local Dask
cluster, `address` a real one, `checkpoint_path` to resume), so a sweep of millions of episodes
can be interrupted and resumed, and spread over machines.

Figures per point (rates in [0, 1], forces N, times s): drops over all episodes and failures
(dropped, or a taking receiver not handed over) with 95 % Wilson intervals; release success
among the taking episodes with its Wilson interval; force overshoot of the taking episodes,
median and p95 with a distribution-free 95 % interval of the p95 (order statistics,
`scipy.stats.quantile_test`); median release time after the grasp start of the handed-over
taking episodes; drops per receiver behaviour.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.studies.engine import run_tasks
from services.studies.gripper.benchmark import wilson_ci
from services.studies.gripper.episodes import BEHAVIOUR_NAMES, EpisodeDistribution
from services.studies.gripper.populations import ChunkPlan, draw_planned_chunk, plan_chunks
from services.studies.gripper.tuning import evaluate

__all__ = ["PointStats", "SweepResult", "point_stats", "run_sweep"]


@dataclass(frozen=True)
class PointStats:
    """The figures of one grid point or reference over the sweep's episodes."""

    label: str
    params: dict[str, float]
    episodes: int
    drops: int
    drop_rate: float
    drop_ci: tuple[float, float]
    failures: int
    failure_rate: float
    failure_ci: tuple[float, float]
    taking_episodes: int
    handed_over: int
    release_success_rate: float
    release_success_ci: tuple[float, float]
    overshoot_median_n: float
    overshoot_p95_n: float
    overshoot_p95_ci_n: tuple[float, float]
    release_time_median_s: float
    drop_rate_by_behaviour: dict[str, float]


@dataclass(frozen=True)
class SweepResult:
    """A sweep's figures: one `PointStats` per grid point (grid order) and per reference."""

    controller: str
    names: list[str]
    points: list[PointStats]
    references: list[PointStats]
    episodes: int
    seed: int
    population: str
    wall_time_s: float
    own_values: dict[str, float]


def _task(argument: tuple) -> dict[str, np.ndarray]:
    """One (controller, parameters) on one planned chunk, alone in its batch: per episode
    dropped, failed, handed over, taking, behaviour, overshoot (N) and release time (s)."""
    controller, params, plan, dist = argument
    chunk, noise = draw_planned_chunk(dist, plan)
    s = evaluate([(chunk, noise)], controller, [dict(params)])
    return {"dropped": s.dropped[0], "failed": s.failed[0], "handed_over": s.handed_over[0],
            "taking": chunk.behaviour == 0, "behaviour": chunk.behaviour.astype(np.int8),
            "overshoot_n": s.overshoot_n[0], "release_time_s": s.release_time_s[0]}


def _p95_ci(values: np.ndarray) -> tuple[float, float]:
    """Distribution-free 95 % interval of the 95th percentile (order statistics)."""
    if values.size < 2:
        return (math.nan, math.nan)
    ci = stats.quantile_test(values, q=float(np.percentile(values, 95)), p=0.95).confidence_interval(0.95)
    return (float(ci.low), float(ci.high))


def point_stats(label: str, params: dict[str, float], parts: list[dict[str, np.ndarray]]) -> PointStats:
    """The figures of one point from its chunks' per-episode columns (chunk order)."""
    col = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    n = int(col["dropped"].size)
    drops, failures = int(col["dropped"].sum()), int(col["failed"].sum())
    take = col["taking"]
    handed = int(col["handed_over"].sum())
    over = col["overshoot_n"][take]
    over = over[np.isfinite(over)]
    rel = col["release_time_s"][np.isfinite(col["release_time_s"])]
    by = {label_b: float(col["dropped"][col["behaviour"] == code].mean()) if (col["behaviour"] == code).any()
          else math.nan for code, label_b in BEHAVIOUR_NAMES.items()}
    n_take = int(take.sum())
    return PointStats(
        label=label, params=dict(params), episodes=n, drops=drops, drop_rate=drops / n, drop_ci=wilson_ci(drops, n),
        failures=failures, failure_rate=failures / n, failure_ci=wilson_ci(failures, n), taking_episodes=n_take,
        handed_over=handed, release_success_rate=handed / n_take if n_take else math.nan,
        release_success_ci=wilson_ci(handed, n_take),
        overshoot_median_n=float(np.median(over)) if over.size else math.nan,
        overshoot_p95_n=float(np.percentile(over, 95)) if over.size else math.nan,
        overshoot_p95_ci_n=_p95_ci(over),
        release_time_median_s=float(np.median(rel)) if rel.size else math.nan, drop_rate_by_behaviour=by)


def run_sweep(controller: str, points: list[dict[str, float]], n_episodes: int, *, seed: int,
              dist: EpisodeDistribution, population: str, chunk_size: int = 1000,
              references: tuple[str, ...] = ("HI",), address: str | None = None, workers: int | None = None,
              checkpoint_path: Path | None = None, show_progress: bool = True) -> SweepResult:
    """Run every grid point (parameters of `controller`) and every reference controller on the
    same `n_episodes` episodes of `dist` and `seed` (the benchmark's chunks of `chunk_size`), on
    the engine; the controller with its own parameters runs as a reference too ("NAME (own)")."""
    if n_episodes < 1 or chunk_size < 1:
        raise GripperError(f"need episodes >= 1 and chunk size >= 1, got {n_episodes} and {chunk_size}")
    if not points:
        raise GripperError("the sweep has no grid point")
    plans: list[ChunkPlan] = plan_chunks(dist, n_episodes, chunk_size, seed)
    runs = [(controller, p) for p in points] + [(controller, {})] + [(r, {}) for r in references if r != controller]
    jobs = [(name, tuple(sorted(params.items())), plan, dist) for name, params in runs for plan in plans]
    t0 = time.perf_counter()
    parts = run_tasks(_task, jobs, address=address, workers=workers, description=f"sweep {controller}",
                      checkpoint_path=checkpoint_path, show_progress=show_progress, unit="ep",
                      weights=[plan.size for _name, _params, plan, _dist in jobs])
    wall = time.perf_counter() - t0
    k = len(plans)
    per_run = [parts[i * k:(i + 1) * k] for i in range(len(runs))]
    labels = [_label(p) for p in points] + [f"{controller} (own)"] + [r for r in references if r != controller]
    figures = [point_stats(lab, params, chunks) for lab, (_name, params), chunks in zip(labels, runs, per_run)]
    return SweepResult(controller=controller, names=list(points[0]), points=figures[:len(points)],
                       references=figures[len(points):], episodes=n_episodes, seed=seed, population=population,
                       wall_time_s=wall, own_values=own_values(controller, list(points[0])))


def own_values(controller: str, names: list[str]) -> dict[str, float]:
    """The controller's own values of the swept parameters (where it sits on the grid)."""
    params = make_controller(controller).params  # type: ignore[attr-defined]
    return {n: float(getattr(params, n)) for n in names}


def _label(params: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in params.items())
