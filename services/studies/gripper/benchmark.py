"""Monte-Carlo benchmark of the release controllers on the realistic contact plant.

Every controller runs the SAME episodes (common random numbers: chunk i of seed s is drawn
from `SeedSequence(s).spawn(...)[i]` whatever the controller), sampled by
`services.studies.gripper.episodes` over pull angle, friction, mass, receiver behaviour and timing,
gripper class and sensor noise, from a named population (`services.studies.gripper.populations`:
"wide" by default, "narrow" the first benchmark's). Each episode is judged from ground truth by
`robot_sim.contact.outcome`. The controllers step at the period of their chunk's gripper class
(`SimConfig.control_period_s`: 10 ms, or the loop's period for a loop faster than 100 Hz).

Per controller:
- drop rate over all episodes, with a 95 % Wilson interval (`scipy.stats.binomtest`);
- release success: handed over (released, not dropped, receiver holds it) among the
  *taking* episodes, with its 95 % interval;
- force overshoot (largest receiver force before the release) over taking episodes:
  median and p95, N;
- release time: release − start of the receiver's grasp, median over handed-over taking
  episodes, s;
- mode chatter: mean number of ground-truth mode switches per episode;
- the drop rate per receiver behaviour;
- all of the above per declared sub-population (receiver kind × gripper class) and overall
  (`subpopulation_stats`): the sub-populations' counts add up to the overall ones.

The tables, CSV and plots of a run: `services.studies.gripper.bench_report`.

Usage:
    handover-study bench                      # CI-sized: 200 episodes each
    handover-study bench -n 10000 --workers 2 --out out/gripper_bench
    handover-study bench --controllers FS1 HI SG -n 2000 --seed 7
    handover-study bench -n 1000000 --controllers SG --address 10.0.0.5:8786 --checkpoint out/bench_ckpt

The chunks (one controller × one chunk each) run on the studies' engine
(`services.studies.engine.run_tasks`, Dask: a local cluster by default, `--address` a real
one, `--checkpoint` to resume); results do not depend on where or in which order they run.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from robot_sim.contact.outcome import BatchOutcome
from services.gripper.controllers.registry import CONTROLLER_NAMES, make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.attribution import (
    DropClass,
    MaxHoldReference,
    ReactiveMaxHold,
    classify_drops,
    paired_overshoot,
    run_attributed,
)
from services.studies.engine import run_tasks
from services.studies.gripper.episodes import (
    BEHAVIOUR_NAMES,
    GRIPPER_CLASSES,
    GRIPPER_CODES,
    EpisodeDistribution,
)
from services.studies.gripper.populations import (
    DEFAULT_POPULATION,
    POPULATIONS,
    ChunkPlan,
    draw_planned_chunk,
    plan_chunks,
    population,
    subpopulations,
)

log = logging.getLogger(__name__)

__all__ = ["BenchResult", "ControllerStats", "DEFAULT_CONTROLLERS", "SubpopulationStats", "run_benchmark", "summarise",
           "subpopulation_stats"]

DEFAULT_CONTROLLERS = ("FS1", "FS2", "FS3", "HI", "force-threshold", "displacement", "SG")
#: Bounds run next to the controllers with `attribute=True` (see services.studies.gripper.attribution).
REFERENCES = {"max-hold": MaxHoldReference, "reactive-max-hold": ReactiveMaxHold}
#: Seed of the episodes the new controller was tuned on; evaluation seeds must differ.
TUNING_SEED = 1000


@dataclass
class BenchResult:
    """Per-controller outcomes over the same episodes, plus the episode draws."""

    outcomes: dict[str, BatchOutcome]
    mass_kg: np.ndarray
    mu_static: np.ndarray
    pull_angle_rad: np.ndarray
    behaviour: np.ndarray
    grasp_start_s: np.ndarray
    seed: int
    wall_time_s: float
    holds_at_release: dict[str, np.ndarray] | None = None
    kind: np.ndarray | None = None
    gripper: np.ndarray | None = None
    dist: EpisodeDistribution | None = None
    population: str = ""
    control_period_s: np.ndarray | None = None


def build_controller(name: str, period_s: float, overrides: dict | None = None):
    """A controller (or reference) of the benchmark that steps every `period_s` (s): the
    period of the chunk it runs in, so that the controller's own integrators (SG's gain,
    the displacement baseline's virtual hand) see the time step they really run at."""
    if name in REFERENCES:
        return REFERENCES[name](period_s=period_s)
    return make_controller(name, period_s=period_s, **(overrides or {}))


def _run_job(args) -> tuple[str, int, BatchOutcome, dict]:
    name, plan, dist, overrides = args
    chunk, noise_seq = draw_planned_chunk(dist, plan)
    controller = build_controller(name, chunk.control_period_s, overrides)
    attributed = run_attributed(chunk.config, chunk.receivers, controller, seed=noise_seq)
    draws = dict(mass_kg=chunk.mass_kg, mu_static=chunk.mu_static, pull_angle_rad=chunk.pull_angle_rad,
                 behaviour=chunk.behaviour, grasp_start_s=chunk.grasp_start_s, kind=chunk.kind,
                 gripper=np.full(plan.size, GRIPPER_CODES[chunk.gripper], dtype=np.int64),
                 control_period_s=np.full(plan.size, controller.period_s))
    return name, plan.index, attributed, draws


def run_benchmark(controllers: list[str], n_episodes: int, seed: int = 1, workers: int | None = None,
                  chunk_size: int = 250, dist: EpisodeDistribution | str | None = None, progress: bool = True,
                  overrides: dict[str, dict] | None = None, attribute: bool = False, address: str | None = None,
                  checkpoint_path: Path | None = None) -> BenchResult:
    """Run `n_episodes` episodes per controller (the same episodes for all), drawn from `dist`
    (a distribution, or the name of one of `POPULATIONS`; default "wide"), on the engine
    (`workers`, `address`, `checkpoint_path`: see `services.studies.engine.run_tasks`).

    With `attribute`, the two references of `services.studies.gripper.attribution` run on the same
    episodes too (`max-hold`, `reactive-max-hold`), so each drop can be attributed."""
    if n_episodes < 1:
        raise GripperError(f"need at least one episode per controller, got {n_episodes}")
    if chunk_size < 1:
        raise GripperError(f"chunk size must be >= 1, got {chunk_size}")
    controllers = list(controllers)
    if attribute:
        controllers += [r for r in REFERENCES if r not in controllers]
    unknown = [c for c in controllers if c not in CONTROLLER_NAMES and c not in REFERENCES]
    if unknown or not controllers:
        raise GripperError(f"unknown controller(s) {unknown}; choose from: {', '.join(CONTROLLER_NAMES)}")
    if not isinstance(dist, EpisodeDistribution):
        dist = population(DEFAULT_POPULATION if dist is None else dist)
    pop_name = next((k for k, d in POPULATIONS.items() if d == dist), "custom")
    overrides = overrides or {}
    plans: list[ChunkPlan] = plan_chunks(dist, n_episodes, chunk_size, seed)
    sizes = [p.size for p in plans]
    jobs = [(name, p, dist, overrides.get(name, {})) for name in controllers for p in plans]
    parts: dict[str, dict[int, BatchOutcome]] = {c: {} for c in controllers}
    draws: dict[int, dict] = {}
    t0 = time.perf_counter()
    results = run_tasks(_run_job, jobs, address=address, workers=workers, description="gripper benchmark",
                        checkpoint_path=checkpoint_path, show_progress=progress, unit="ep",
                        weights=[job[1].size for job in jobs])
    for name, i, out, d in results:
        parts[name][i] = out
        draws[i] = d
    wall = time.perf_counter() - t0
    cat = lambda key: np.concatenate([draws[i][key] for i in range(len(sizes))])  # noqa: E731
    outcomes = {c: BatchOutcome.concatenate([parts[c][i].outcome for i in range(len(sizes))]) for c in controllers}
    holds = {c: np.concatenate([parts[c][i].holds_at_release for i in range(len(sizes))]) for c in controllers}
    return BenchResult(outcomes=outcomes, mass_kg=cat("mass_kg"), mu_static=cat("mu_static"),
                       pull_angle_rad=cat("pull_angle_rad"), behaviour=cat("behaviour"),
                       grasp_start_s=cat("grasp_start_s"), seed=seed, wall_time_s=wall, holds_at_release=holds,
                       kind=cat("kind"), gripper=cat("gripper"), dist=dist, population=pop_name,
                       control_period_s=cat("control_period_s"))


# --------------------------------------------------------------------------- statistics


def wilson_ci(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a proportion (scipy.stats.binomtest); (nan, nan) for 0 trials."""
    if trials == 0:
        return (math.nan, math.nan)
    ci = stats.binomtest(int(successes), int(trials)).proportion_ci(confidence_level=level, method="wilson")
    return (float(ci.low), float(ci.high))


@dataclass(frozen=True)
class ControllerStats:
    """Benchmark figures of one controller (rates in [0, 1], forces in N, times in s)."""

    controller: str
    episodes: int
    drops: int
    drop_rate: float
    drop_ci: tuple[float, float]
    taking_episodes: int
    release_success_rate: float
    release_success_ci: tuple[float, float]
    overshoot_median_n: float
    overshoot_p95_n: float
    release_time_median_s: float
    mode_switches_mean: float
    drop_rate_by_behaviour: dict[str, float]
    handed_over: int | None = None
    held_to_end: int | None = None

    def row(self) -> dict:
        """Flat dict for CSV."""
        d = {"controller": self.controller, "episodes": self.episodes, "drops": self.drops,
             "drop_rate": self.drop_rate, "drop_ci_low": self.drop_ci[0], "drop_ci_high": self.drop_ci[1],
             "taking_episodes": self.taking_episodes, "handed_over": self.handed_over,
             "held_to_end": self.held_to_end,
             "release_success_rate": self.release_success_rate,
             "release_success_ci_low": self.release_success_ci[0],
             "release_success_ci_high": self.release_success_ci[1],
             "overshoot_median_n": self.overshoot_median_n, "overshoot_p95_n": self.overshoot_p95_n,
             "release_time_median_s": self.release_time_median_s, "mode_switches_mean": self.mode_switches_mean}
        d.update({f"drop_rate_{k}": v for k, v in self.drop_rate_by_behaviour.items()})
        return d


def _pct(a: np.ndarray, q: float) -> float:
    return float(np.percentile(a, q)) if a.size else math.nan


def controller_stats(name: str, outcome: BatchOutcome, behaviour: np.ndarray, grasp_start_s: np.ndarray,
                     mask: np.ndarray | None = None) -> ControllerStats:
    """Figures of one controller over the episodes selected by `mask` (all by default).
    `held_to_end`: taking episodes neither released nor dropped when the episode ended (the
    gripper kept the object from a receiver who wanted it)."""
    sel = np.ones(len(outcome), dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    dropped = outcome.dropped[sel]
    beh = behaviour[sel]
    take = beh == 0
    handed = outcome.handed_over[sel][take]
    over = outcome.force_overshoot_n[sel][take]
    rel_t = (outcome.release_time_s[sel] - grasp_start_s[sel])[take & outcome.handed_over[sel]]
    n = int(sel.sum())
    by_beh = {}
    for code, label in BEHAVIOUR_NAMES.items():
        m = beh == code
        by_beh[label] = float(dropped[m].mean()) if m.any() else math.nan
    return ControllerStats(
        controller=name, episodes=n, drops=int(dropped.sum()),
        drop_rate=float(dropped.mean()) if n else math.nan, drop_ci=wilson_ci(int(dropped.sum()), n),
        taking_episodes=int(take.sum()),
        release_success_rate=float(handed.mean()) if handed.size else math.nan,
        release_success_ci=wilson_ci(int(handed.sum()), int(handed.size)),
        overshoot_median_n=_pct(over, 50), overshoot_p95_n=_pct(over, 95),
        release_time_median_s=_pct(rel_t, 50),
        mode_switches_mean=float(outcome.mode_switch_count[sel].mean()) if n else math.nan,
        drop_rate_by_behaviour=by_beh, handed_over=int(handed.sum()),
        held_to_end=int((~outcome.released[sel][take] & ~dropped[take]).sum()),
    )


def summarise(result: BenchResult) -> list[ControllerStats]:
    """Per-controller figures, in the order the controllers were run (references left out)."""
    return [controller_stats(name, out, result.behaviour, result.grasp_start_s)
            for name, out in result.outcomes.items() if name not in REFERENCES]


@dataclass(frozen=True)
class SubpopulationStats:
    """Figures of one controller over one sub-population (receiver and gripper labels of
    `populations.SubPopulation`; both "all" for the overall figures)."""

    receiver: str
    gripper: str
    stats: ControllerStats


def subpopulation_stats(result: BenchResult) -> list[SubpopulationStats]:
    """One row per declared sub-population per controller (sub-population by
    sub-population, the controllers in run order), then one overall row per controller.
    Every episode is in exactly one sub-population, so the episodes, drops, taking episodes
    and handovers of a controller's rows add up to its overall row's."""
    if result.kind is None or result.gripper is None or result.dist is None:
        raise GripperError("per-sub-population figures need a run of run_benchmark (episode kinds and grippers)")
    names = [n for n in result.outcomes if n not in REFERENCES]
    rows = []
    for sp in subpopulations(result.dist):
        mask = sp.mask(result.kind, result.gripper)
        for n in names:
            stats_n = controller_stats(n, result.outcomes[n], result.behaviour, result.grasp_start_s, mask)
            rows.append(SubpopulationStats(sp.receiver_label, sp.gripper_label, stats_n))
    return rows + [SubpopulationStats("all", "all", s) for s in summarise(result)]


def per_gripper_stats(result: BenchResult) -> list[SubpopulationStats]:
    """One row per gripper class of the run per controller, over every receiver kind of that
    class (receiver label "all"), gripper by gripper in the distribution's order."""
    if result.gripper is None or result.dist is None:
        raise GripperError("per-gripper figures need a run of run_benchmark (episode grippers)")
    names = [n for n in result.outcomes if n not in REFERENCES]
    rows = []
    for g, weight in result.dist.gripper_weights.items():
        mask = np.asarray(result.gripper) == GRIPPER_CODES[g]
        if weight > 0 and mask.any():
            rows += [SubpopulationStats("all", GRIPPER_CLASSES[g].label, controller_stats(
                n, result.outcomes[n], result.behaviour, result.grasp_start_s, mask)) for n in names]
    return rows


def per_gripper_paired_tests(result: BenchResult, against: str = "SG") -> list[dict]:
    """`paired_drop_test` of `against` with every other controller on each gripper class's
    episodes (key ``gripper``: the class's label); [] when `against` did not run."""
    if against not in result.outcomes or result.gripper is None or result.dist is None:
        return []
    tests = []
    for g, weight in result.dist.gripper_weights.items():
        mask = np.asarray(result.gripper) == GRIPPER_CODES[g]
        if weight > 0 and mask.any():
            tests += [{"gripper": GRIPPER_CLASSES[g].label, **paired_drop_test(result, against, other, mask)}
                      for other in result.outcomes if other != against and other not in REFERENCES]
    return tests


def drop_attribution(result: BenchResult) -> list[dict]:
    """Per controller: drop rate split into unavoidable (the max-hold reference drops too),
    actuator-limited (the reactive reference drops too: only a harder grip *before* any
    sensor signal would have held it; non-taking episodes), receiver-let-go and controller
    drops, as fractions of all episodes; plus the controller drops per behaviour.
    Needs a run with `attribute=True`."""
    if not all(r in result.outcomes for r in REFERENCES):
        raise GripperError("drop attribution needs a benchmark run with attribute=True")
    from services.studies.gripper.attribution import AttributedOutcome

    ref = result.outcomes["max-hold"].dropped
    react = result.outcomes["reactive-max-hold"].dropped & (result.behaviour != 0)
    rows = []
    for name, out in result.outcomes.items():
        if name in REFERENCES:
            continue
        cls = classify_drops(AttributedOutcome(out, result.holds_at_release[name]), ref)
        limited = (cls == DropClass.CONTROLLER) & react
        own = (cls == DropClass.CONTROLLER) & ~react
        row = {"controller": name, "drop_rate": float(out.dropped.mean()),
               "unavoidable_rate": float(np.mean(cls == DropClass.UNAVOIDABLE)),
               "actuator_limited_rate": float(limited.mean()),
               "receiver_let_go_rate": float(np.mean(cls == DropClass.RECEIVER_LET_GO)),
               "controller_drop_rate": float(own.mean()),
               "controller_drop_ci": wilson_ci(int(own.sum()), own.size)}
        for code, label in BEHAVIOUR_NAMES.items():
            m = result.behaviour == code
            row[f"controller_drop_rate_{label}"] = float(own[m].mean()) if m.any() else math.nan
        rows.append(row)
    return rows


def paired_overshoot_rows(result: BenchResult, against: str = "SG") -> list[dict]:
    """Force overshoot of `against` and every other controller on the taking episodes both
    handed over (`services.studies.gripper.attribution.paired_overshoot`)."""
    take = result.behaviour == 0
    rows = []
    for name, out in result.outcomes.items():
        if name in REFERENCES or name == against:
            continue
        rows.append({"other": name, **paired_overshoot(result.outcomes[against], out, take, ci=True)})
    return rows


def paired_drop_test(result: BenchResult, a: str, b: str, mask: np.ndarray | None = None) -> dict:
    """McNemar's exact test on the same episodes (those in `mask`, default all): does `a`
    drop differently from `b`?

    Returns the discordant counts (a drops where b holds, and the reverse) and the
    two-sided p-value (binomial test on the discordant pairs)."""
    da, db = result.outcomes[a].dropped, result.outcomes[b].dropped
    if mask is not None:
        da, db = da[mask], db[mask]
    only_a, only_b = int((da & ~db).sum()), int((~da & db).sum())
    p = stats.binomtest(only_a, only_a + only_b).pvalue if only_a + only_b else 1.0
    return {"a": a, "b": b, "only_a_drops": only_a, "only_b_drops": only_b, "p_value": float(p)}
