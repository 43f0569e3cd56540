"""Automatic tuning of a release controller: the search spaces, the declared objective, and the
batched evaluation of many parameter sets on the same episodes.

Objective (lower is better), over the tuning episodes, for one parameter set:

    J = failure rate                                      (dropped, or a taking receiver not handed over)
      + (drop weight − 1) × drop rate                     (`--drop-weight`, default 1: a drop counts as
                                                           one failure, like a refused handover)
      + 0.005 / N  × p95 force overshoot                  (all taking episodes, the benchmark table's p95)
      + 0.05  / s  × median release time                  (after the receiver's grasp starts, handed over)
      + 0.05  / N  × max(0, p95 overshoot − HI's p95)     (HI run on the same episodes and noise)

Why these weights: the failure rate is what a user pays for (an object on the floor, or a
receiver who cannot get it) and the same outcome the oracle bound counts, so tuned figures and
the bound compare directly. The overshoot and the release time are secondary: 1 N of p95
overshoot is worth 0.5 failure points and 100 ms of release time 0.5 points, so across the range
the benchmark's laws span (p95 16–28 N, median release 0.40–0.50 s) they move J by a few
points at most and break ties between laws that fail equally often. The hinge is the issue's
constraint "no larger p95 overshoot than HI" as a penalty: 5 failure points per N above HI's p95
on the same episodes (the same weight as the oracle's capped family member), so a law that buys
drops with a harder pull is pushed back under HI's tail. With the default drop weight of 1 a
law may trade refused handovers for drops one for one (CMA-ES found such a law for SG: SG-tuned);
`--drop-weight 3` says a fallen object costs three refused handovers, which a lab may prefer.

Every parameter set of a generation runs in ONE vectorised batch per chunk (the chunk's episodes
tiled once per set, each set's controller stepping its own slice: `SplitController`), with the
chunk's sensor-noise seed. Every set runs the same episodes, but the plant draws sensor noise per
batch position, so each set sees its own noise draw (J is deterministic for a given generation,
and a set's figures move by a few episodes between positions: `tune_cma` re-runs the best alone).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from handover_model.grip import SensorSample
from robot_sim.contact.episode import run_vectorised
from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.episodes import ChunkSpec
from services.studies.gripper.oracle import subset_episodes
from services.studies.gripper.oracle_family import taking_overshoot_p95_n

__all__ = ["OBJECTIVE_WEIGHTS", "SPACES", "ParamSpace", "Runner", "Scores", "SplitController", "engine_runner",
           "evaluate", "evaluate_chunk", "hi_p95_n"]

#: Weights of the objective (module docstring): per N of p95 overshoot, per s of median release
#: time, per N of p95 overshoot above HI's.
OBJECTIVE_WEIGHTS = {"overshoot_p95_per_n": 0.005, "release_time_per_s": 0.05, "above_hi_per_n": 0.05}

Chunks = list[tuple[ChunkSpec, np.random.SeedSequence]]
#: How `evaluate` runs its per-chunk tasks: runner(function, arguments) → results in order.
Runner = Callable[[Callable, list], list]


@dataclass(frozen=True)
class ParamSpace:
    """The searched parameters of one registered controller: name → (low, high, log scale).
    The optimiser works in the unit cube [0, 1]^d (log-scaled parameters map log-uniformly)."""

    controller: str
    bounds: dict[str, tuple[float, float, bool]]

    @property
    def names(self) -> list[str]:
        return list(self.bounds)

    def to_params(self, u) -> dict[str, float]:
        """Unit-cube point → controller parameters (clipped to the box; constraints applied)."""
        out = {}
        for (name, (lo, hi, log)), x in zip(self.bounds.items(), np.clip(np.ravel(u), 0.0, 1.0)):
            out[name] = float(math.exp(math.log(lo) + x * math.log(hi / lo)) if log else lo + x * (hi - lo))
        if "zero_load_grip_force_n" in out:  # HI: F_ZLG < F_Go
            out["zero_load_grip_force_n"] = min(out["zero_load_grip_force_n"], 0.9 * out["initial_grip_force_n"])
        if "max_hold_force_n" in out and "min_hold_force_n" in out:
            out["max_hold_force_n"] = max(out["max_hold_force_n"], out["min_hold_force_n"] + 0.5)
        return out

    def to_unit(self, params: dict[str, float]) -> np.ndarray:
        """Controller parameters → unit-cube point (the optimiser's start)."""
        u = []
        for name, (lo, hi, log) in self.bounds.items():
            v = float(np.clip(params[name], lo, hi))
            u.append(math.log(v / lo) / math.log(hi / lo) if log else (v - lo) / (hi - lo))
        return np.array(u)

    def defaults(self) -> dict[str, float]:
        """The registered controller's current values of the searched parameters."""
        ctrl = make_controller(self.controller)
        params = ctrl.params  # type: ignore[attr-defined]
        return {name: float(getattr(params, name)) for name in self.bounds}


#: The searched parameters per controller. SG: its hold, cap, release share, slip guard and catch
#: (the slide memory, ease-off and F_eps stay fixed); HI: its three forces (eq 3.22); IG: SG's
#: core plus the intent gate's thresholds.
SPACES: dict[str, ParamSpace] = {
    "SG": ParamSpace("SG", {
        "hold_per_weight": (2.0, 15.0, True), "max_hold_force_n": (8.0, 80.0, True),
        "release_share": (0.1, 0.9, False), "share_cap": (1.0, 3.0, False), "guard_share": (0.5, 0.98, False),
        "adapt_rate_per_s": (1.0, 100.0, True), "slip_speed_threshold_m_s": (0.002, 0.02, True),
        "fall_steepness": (0.5, 4.0, True)}),
    "HI": ParamSpace("HI", {
        "initial_grip_force_n": (5.0, 60.0, True), "release_load_n": (-8.0, -0.1, False),
        "zero_load_grip_force_n": (0.5, 20.0, True)}),
}


class SplitController:
    """Runs S controllers side by side on one batch: controller i steps the episodes of slice i
    (consecutive blocks of `block` episodes), so S parameter sets share one plant run."""

    def __init__(self, controllers: list, block: int, period_s: float) -> None:
        self.controllers, self.block, self.period_s = list(controllers), int(block), float(period_s)

    def reset(self, n_episodes: int = 1) -> None:
        if n_episodes != self.block * len(self.controllers):
            raise GripperError(f"SplitController: {n_episodes} episodes, expected {len(self.controllers)} × "
                               f"{self.block}")
        for c in self.controllers:
            c.reset(self.block)

    def step(self, sample: SensorSample) -> np.ndarray:
        out = np.empty(self.block * len(self.controllers))
        for i, c in enumerate(self.controllers):
            sl = slice(i * self.block, (i + 1) * self.block)
            out[sl] = c.step(_slice_sample(sample, sl))
        return out


def _slice_sample(sample: SensorSample, sl: slice) -> SensorSample:
    """The episodes `sl` of a batch's sample (scalar fields shared)."""
    values = {f.name: getattr(sample, f.name) for f in dataclasses.fields(sample)}
    return SensorSample(**{k: (v[sl] if np.ndim(v) else v) for k, v in values.items()})


@dataclass(frozen=True)
class Scores:
    """Per parameter set (rows) and tuning episode (columns): failed, dropped, handed over, force
    overshoot of the taking episodes (N, NaN for the others) and release time after the grasp
    start of the handed-over ones (s, NaN otherwise)."""

    failed: np.ndarray
    dropped: np.ndarray
    handed_over: np.ndarray
    overshoot_n: np.ndarray
    release_time_s: np.ndarray

    def overshoot_p95_n(self) -> np.ndarray:
        """p95 overshoot over all taking episodes, per set, N."""
        return taking_overshoot_p95_n(self.overshoot_n)

    def release_time_median_s(self) -> np.ndarray:
        """Median release time of the handed-over taking episodes, per set (s; 3.5 s, the episode's
        length, for a set that hands nothing over)."""
        rel = self.release_time_s
        has = np.isfinite(rel).any(axis=1)
        med = np.nanmedian(np.where(has[:, None], rel, 0.0), axis=1)
        return np.where(has, med, 3.5)

    def objective(self, hi_p95_n: float, drop_weight: float = 1.0, above_hi_per_n: float | None = None) -> np.ndarray:
        """J per set (module docstring), given HI's p95 overshoot on the same episodes (N); a drop
        counts `drop_weight` failures (≥ 1; a drop is also a failure); `above_hi_per_n` replaces the
        weight of each N of p95 overshoot above HI's (per N; default `OBJECTIVE_WEIGHTS`')."""
        w = OBJECTIVE_WEIGHTS
        above = w["above_hi_per_n"] if above_hi_per_n is None else above_hi_per_n
        p95 = self.overshoot_p95_n()
        return (self.failed.mean(axis=1) + (drop_weight - 1.0) * self.dropped.mean(axis=1)
                + w["overshoot_p95_per_n"] * p95
                + w["release_time_per_s"] * self.release_time_median_s()
                + above * np.maximum(p95 - hi_p95_n, 0.0))

    def summary(self, i: int, hi_p95_n: float, drop_weight: float = 1.0, above_hi_per_n: float | None = None) -> dict:
        """Figures of set i (rates in [0, 1], N, s)."""
        return {"objective": float(self.objective(hi_p95_n, drop_weight, above_hi_per_n)[i]),
                "failure_rate": float(self.failed[i].mean()),
                "drop_rate": float(self.dropped[i].mean()), "overshoot_p95_n": float(self.overshoot_p95_n()[i]),
                "release_time_median_s": float(self.release_time_median_s()[i]), "hi_overshoot_p95_n": hi_p95_n}


def evaluate(chunks: Chunks, controller: str, param_sets: list[dict], runner: Runner | None = None) -> Scores:
    """Run every parameter set of `controller` on the episodes of `chunks` (one batch per chunk).
    `runner`: how the chunks' tasks run, ``runner(function, arguments) -> results`` (e.g.
    `services.studies.engine.run_tasks` on a cluster, `engine_runner`); default here, one after
    the other. Each chunk's batch is the same wherever it runs, so the scores are too."""
    if not param_sets:
        raise GripperError("nothing to evaluate: no parameter set")
    tasks = [(chunk, noise, controller, [dict(p) for p in param_sets]) for chunk, noise in chunks]
    parts = [evaluate_chunk(t) for t in tasks] if runner is None else runner(evaluate_chunk, tasks)
    return Scores(*(np.concatenate([part[k] for part in parts], axis=1) for k in range(5)))


def evaluate_chunk(task: tuple) -> tuple[np.ndarray, ...]:
    """One chunk's batch of every parameter set (`evaluate`'s task): failed, dropped, handed over,
    overshoot (N) and release time (s), each of shape (sets, chunk episodes)."""
    chunk, noise, controller, param_sets = task
    s, n = len(param_sets), chunk.behaviour.size
    cfg, rec = subset_episodes(chunk.config, chunk.receivers, np.tile(np.arange(n), s))
    period = chunk.control_period_s
    law = SplitController([make_controller(controller, period_s=period, **p) for p in param_sets], n, period)
    out = run_vectorised(cfg, rec, law, seed=noise)
    take = np.tile(chunk.behaviour == 0, s)
    rel = out.release_time_s - np.tile(chunk.grasp_start_s, s)
    cols = (out.dropped | (take & ~out.handed_over), out.dropped, take & out.handed_over,
            np.where(take, out.force_overshoot_n, np.nan), np.where(take & out.handed_over, rel, np.nan))
    return tuple(np.asarray(c).reshape(s, n) for c in cols)


def engine_runner(client: Any) -> Runner:
    """A `runner` for `evaluate` on the engine: the chunks' tasks through
    `services.studies.engine.run_tasks` on `client` (of `engine.open_cluster`; None: here)."""
    from services.studies.engine import run_tasks

    def run(function: Callable, arguments: list) -> list:
        return run_tasks(function, arguments, client=client, workers=1 if client is None else None,
                         description="tune", show_progress=False)
    return run


def hi_p95_n(chunks: Chunks, runner: Runner | None = None) -> float:
    """HI's p95 force overshoot over the taking episodes of `chunks` (same noise), N."""
    return float(evaluate(chunks, "HI", [{}], runner).overshoot_p95_n()[0])
