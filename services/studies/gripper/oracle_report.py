"""The oracle bound next to the benchmark: what was possible on the benchmark's own episodes,
and each controller's gap to it, per receiver behaviour.

For a `handover-study bench` run (`benchmark.BenchResult`) this module redraws the same
episodes (chunk by chunk, with the benchmark's seeds; the draws are checked against the run)
and computes on them:

- the clairvoyant bound (`oracle.clairvoyant_bound`): per episode, whether any admissible grip
  sequence keeps the object (non-taking receivers) or hands it over without a drop (taking);
  the drops it cannot avoid are **unavoidable**;
- the sensor-only family bound (`oracle_family`), with the parameters tuned on the tuning seed
  (`oracle_family_params.json`): the global member (one law for all episodes) and the
  per-class members (the law is told the behaviour), run on the same episodes and the same
  sensor noise as the controllers.

A **failure** is a drop, or a taking episode not handed over. Each controller's gap to a bound
is the difference of failure rates on the same episodes, in points, with a paired bootstrap
95 % interval (`scipy.stats.bootstrap` of the mean per-episode difference); rates carry 95 %
Wilson intervals (`benchmark.wilson_ci`).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from robot_sim.contact.episode import run_vectorised
from robot_sim.contact.outcome import BatchOutcome
from services.gripper.errors import GripperError
from services.studies.engine import run_tasks
from services.studies.gripper.benchmark import REFERENCES, BenchResult, wilson_ci
from services.studies.gripper.episodes import BEHAVIOUR_NAMES, EpisodeDistribution
from services.studies.gripper.oracle import ClairvoyantResult, clairvoyant_bound
from services.studies.gripper.oracle_family import PARAMS_PATH, ShareReleaseLaw, TunedFamily, bench_chunk, bench_chunks

__all__ = ["OracleResult", "bound_rows", "failed", "gap_rows", "oracle_summary", "overshoot_rows", "run_oracle"]

GROUPS = ("all", "taking", "dropping", "hesitating", "bumping")
FAMILY_LABELS = {"family": "family, global", "family_capped": "family, global, p95 ≤ HI",
                 "family_class": "family, per class"}


@dataclass
class OracleResult:
    """Bounds on the episodes of one benchmark run (arrays of shape (n,), episode order)."""

    clairvoyant: ClairvoyantResult
    family: BatchOutcome
    family_capped: BatchOutcome
    family_class: BatchOutcome
    behaviour: np.ndarray
    wall_time_s: float


def failed(outcome: BatchOutcome, behaviour: np.ndarray) -> np.ndarray:
    """Failure per episode: dropped, or a taking episode not handed over."""
    return outcome.dropped | ((np.asarray(behaviour) == 0) & ~outcome.handed_over)


def _oracle_job(args) -> tuple[int, ClairvoyantResult, BatchOutcome, BatchOutcome, BatchOutcome]:
    seed, n_episodes, chunk_size, index, dist, tuned, search = args
    chunk, noise = bench_chunk(seed, n_episodes, chunk_size, index, dist)
    period_s = chunk.control_period_s  # the family steps at the chunk's control rate, as the controllers do
    bound = clairvoyant_bound(chunk.config, chunk.receivers, search=search, seed=index)
    family = run_vectorised(chunk.config, chunk.receivers, ShareReleaseLaw.of(tuned.global_params, period_s),
                            seed=noise)
    capped = run_vectorised(chunk.config, chunk.receivers, ShareReleaseLaw.of(tuned.capped, period_s), seed=noise)
    members = tuned.class_members(chunk.behaviour)
    family_class = run_vectorised(chunk.config, chunk.receivers, ShareReleaseLaw(*members.T, period_s=period_s),
                                  seed=noise)
    return index, bound, family, capped, family_class


def run_oracle(result: BenchResult, n_episodes: int, chunk_size: int = 250, dist: EpisodeDistribution | None = None,
               workers: int | None = 1, params_path: Path = PARAMS_PATH, search: int = 64, address: str | None = None,
               checkpoint_path: Path | None = None, show_progress: bool = False) -> OracleResult:
    """The bounds on the episodes of `result` (a run of `n_episodes` with `chunk_size`), chunk
    by chunk on the engine (`workers`, `address`, `checkpoint_path`: see
    `services.studies.engine.run_tasks`)."""
    tuned = TunedFamily.load(params_path)
    dist = dist if dist is not None else result.dist
    draws = [chunk for chunk, _noise in bench_chunks(result.seed, n_episodes, chunk_size, dist)]
    n_chunks = len(draws)
    behaviour = np.concatenate([c.behaviour for c in draws])
    if not (np.array_equal(np.concatenate([c.mass_kg for c in draws]), result.mass_kg)
            and np.array_equal(behaviour, result.behaviour)):
        raise GripperError("the oracle's redrawn episodes differ from the benchmark's: the episode seeding of "
                           "benchmark.run_benchmark and oracle_family.bench_chunk no longer agree")
    jobs = [(result.seed, n_episodes, chunk_size, i, dist, tuned, search) for i in range(n_chunks)]
    t0 = time.perf_counter()
    parts = run_tasks(_oracle_job, jobs, address=address, workers=workers, description="oracle bound",
                      checkpoint_path=checkpoint_path, show_progress=show_progress, unit="ep",
                      weights=[c.behaviour.size for c in draws])
    return OracleResult(clairvoyant=ClairvoyantResult.concatenate([p[1] for p in parts]),
                        family=BatchOutcome.concatenate([p[2] for p in parts]),
                        family_capped=BatchOutcome.concatenate([p[3] for p in parts]),
                        family_class=BatchOutcome.concatenate([p[4] for p in parts]),
                        behaviour=behaviour, wall_time_s=time.perf_counter() - t0)


def mean_difference_ci(d: np.ndarray, level: float = 0.95, n_resamples: int = 2000,
                       seed: int = 0) -> tuple[float, float, float]:
    """Mean of paired differences with a bootstrap interval (`scipy.stats.bootstrap`, BCa,
    percentile where BCa is undefined); a constant sample gives a zero-width interval."""
    d = np.asarray(d, dtype=float)
    if d.size == 0:
        return (math.nan, math.nan, math.nan)
    mean = float(d.mean())
    if np.all(d == d[0]) or d.size < 2:
        return (mean, mean, mean)
    low = high = math.nan
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = stats.bootstrap((d,), np.mean, vectorized=True, n_resamples=n_resamples, confidence_level=level,
                                  method=method, random_state=np.random.default_rng(seed))
        low, high = (float(v) for v in res.confidence_interval)
        if math.isfinite(low) and math.isfinite(high):
            break
    return (mean, low, high)


def _groups(behaviour: np.ndarray):
    yield "all", np.ones(behaviour.size, dtype=bool)
    for label in GROUPS[1:]:
        code = next(c for c, name in BEHAVIOUR_NAMES.items() if name == label)
        yield label, behaviour == code


def _rate(flags: np.ndarray) -> dict:
    k, n = int(flags.sum()), int(flags.size)
    lo, hi = wilson_ci(k, n)
    return {"rate": k / n if n else math.nan, "ci": (lo, hi)}


def bound_rows(oracle: OracleResult) -> list[dict]:
    """Per behaviour group: episodes, unavoidable drops, the clairvoyant failure rate, the
    family's failure (and drop) rate, global and per class (rates in [0, 1] with Wilson CIs)."""
    c, b = oracle.clairvoyant, oracle.behaviour
    rows = []
    for label, m in _groups(b):
        row = {"group": label, "episodes": int(m.sum()), "unavoidable": _rate(c.dropped[m]),
               "clairvoyant_fail": _rate(~c.success[m]), "searched": int(c.searched[m].sum()),
               "found_by_search": int((c.source[m] == 1).sum())}
        for key, out in _family(oracle).items():
            row[f"{key}_fail"], row[f"{key}_drop"] = _rate(failed(out, b)[m]), _rate(out.dropped[m])
        rows.append(row)
    return rows


def _family(oracle: OracleResult) -> dict[str, BatchOutcome]:
    return {"family": oracle.family, "family_capped": oracle.family_capped, "family_class": oracle.family_class}


def overshoot_rows(result: BenchResult, oracle: OracleResult) -> list[dict]:
    """Force overshoot (N) over the taking episodes each of them handed over: the bounds' best
    sequences and laws, and every controller (a low failure rate bought with hard pulls shows here)."""
    take = oracle.behaviour == 0
    c = oracle.clairvoyant
    entries = [("clairvoyant", c.handed_over, c.overshoot_n)]
    entries += [(FAMILY_LABELS[key], out.handed_over, out.force_overshoot_n) for key, out in _family(oracle).items()]
    entries += [(name, out.handed_over, out.force_overshoot_n) for name, out in result.outcomes.items()
                if name not in REFERENCES]
    rows = []
    for name, handed, over in entries:
        x = over[take & handed]
        rows.append({"who": name, "handed_over": int(x.size), "taking": int(take.sum()),
                     "median_n": float(np.median(x)) if x.size else math.nan,
                     "p95_n": float(np.percentile(x, 95)) if x.size else math.nan,
                     "p95_all_taking_n": float(np.percentile(over[take], 95)) if take.any() else math.nan})
    return rows


def gap_rows(result: BenchResult, oracle: OracleResult) -> list[dict]:
    """Per controller and behaviour group: drop and failure rates (Wilson CIs) and the gap of the
    failure rate to each bound (points as fractions, paired bootstrap CIs); also the episodes
    where the controller succeeded and the clairvoyant bound did not (0 for a valid bound)."""
    b = oracle.behaviour
    bounds = {"clairvoyant": ~oracle.clairvoyant.success}
    bounds.update({key: failed(out, b) for key, out in _family(oracle).items()})
    rows = []
    for name, out in result.outcomes.items():
        if name in REFERENCES:
            continue
        fail = failed(out, b)
        for label, m in _groups(b):
            row = {"controller": name, "group": label, "episodes": int(m.sum()), "drop": _rate(out.dropped[m]),
                   "fail": _rate(fail[m]), "beats_clairvoyant": int((~fail & bounds["clairvoyant"])[m].sum())}
            for key, bound in bounds.items():
                row[f"gap_{key}"] = mean_difference_ci(fail[m].astype(float) - bound[m].astype(float))
            rows.append(row)
    return rows


# --------------------------------------------------------------------------- tables and CSV


def _pct(r: dict) -> str:
    lo, hi = r["ci"]
    return "–" if math.isnan(r["rate"]) else f"{100 * r['rate']:.1f} [{100 * lo:.1f}, {100 * hi:.1f}]"


def _points(t: tuple[float, float, float]) -> str:
    v, lo, hi = t
    return "–" if math.isnan(v) else f"{100 * v:+.1f} [{100 * lo:+.1f}, {100 * hi:+.1f}]"


def bounds_table(rows: list[dict]) -> str:
    """Markdown table of `bound_rows` (rates in % with 95 % Wilson CIs)."""
    lines = ["| behaviour | episodes | unavoidable drops % | clairvoyant failures % | "
             + " | ".join(f"{label}: failures % / drops %" for label in FAMILY_LABELS.values()) + " |",
             "|" + "---|" * 7]
    for r in rows:
        cells = [f"{_pct(r[f'{key}_fail'])} / {100 * r[f'{key}_drop']['rate']:.1f}" for key in FAMILY_LABELS]
        lines.append(f"| {r['group']} | {r['episodes']} | {_pct(r['unavoidable'])} | {_pct(r['clairvoyant_fail'])} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def gaps_table(rows: list[dict]) -> str:
    """Markdown table of `gap_rows`: rates in %, gaps in points (controller − bound), 95 % CIs."""
    keys = ["clairvoyant", *FAMILY_LABELS]
    labels = ["clairvoyant", *FAMILY_LABELS.values()]
    lines = ["| controller | behaviour | drops % | failures % | "
             + " | ".join(f"gap to {label}, points" for label in labels) + " |", "|" + "---|" * 8]
    for r in rows:
        lines.append(f"| {r['controller']} | {r['group']} | {_pct(r['drop'])} | {_pct(r['fail'])} | "
                     + " | ".join(_points(r[f"gap_{k}"]) for k in keys) + " |")
    return "\n".join(lines)


def _window(oracle: OracleResult) -> str:
    """Median and p10 of the clairvoyant's release window over the taking episodes (latches)."""
    w = oracle.clairvoyant.release_window[oracle.behaviour == 0]
    return f"{np.median(w):.0f} (p10 {np.percentile(w, 10):.0f})" if w.size else "–"


def overshoot_table(rows: list[dict]) -> str:
    """Markdown table of `overshoot_rows`."""
    lines = ["| who | taking episodes handed over | overshoot median / p95 N, handed over "
             "| overshoot p95 N, all taking |", "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['who']} | {r['handed_over']} / {r['taking']} | {r['median_n']:.2f} / {r['p95_n']:.2f} "
                     f"| {r['p95_all_taking_n']:.2f} |")
    return "\n".join(lines)


def _flat(row: dict) -> dict:
    flat: dict = {}
    for key, value in row.items():
        if isinstance(value, dict):
            flat[key] = value["rate"]
            flat[f"{key}_ci_low"], flat[f"{key}_ci_high"] = value["ci"]
        elif isinstance(value, tuple):
            flat[key], flat[f"{key}_ci_low"], flat[f"{key}_ci_high"] = value
        else:
            flat[key] = value
    return flat


def write_oracle_csv(rows: list[dict], path: Path) -> Path:
    """One CSV row per table row (rates and gaps as fractions, CIs in their own columns)."""
    import csv

    path.parent.mkdir(parents=True, exist_ok=True)
    flat = [_flat(r) for r in rows]
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(flat[0]))
        writer.writeheader()
        writer.writerows(flat)
    return path


def oracle_summary(result: BenchResult, oracle: OracleResult, out_dir: Path) -> tuple[str, list[Path]]:
    """Both tables as text (with the checks), written to `out_dir` as oracle.md, oracle_bounds.csv
    and oracle_gaps.csv."""
    bounds, gaps = bound_rows(oracle), gap_rows(result, oracle)
    c = oracle.clairvoyant
    beaten = sorted({r["controller"] for r in gaps if r["group"] == "all" and r["beats_clairvoyant"]})
    text = "\n".join([
        f"Oracle bound on the same {len(c)} episodes ({oracle.wall_time_s:.1f} s; services/studies/gripper/oracle.py): "
        f"failure = a drop, or a taking episode not handed over.", "",
        bounds_table(bounds), "",
        f"Clairvoyant: release latches that hand over, per taking episode: median {_window(oracle)}; "
        f"max-hold drops {int(c.max_hold_dropped.sum())}; falsification search on "
        f"{int(c.searched.sum())} episodes, better than the envelope family on {int((c.source == 1).sum())}; "
        f"controllers that succeeded where the clairvoyant bound failed: {', '.join(beaten) or 'none'}.", "",
        gaps_table(gaps), "",
        "Force overshoot (N) on the taking episodes each handed over, and over all taking episodes "
        "(the benchmark table's p95):", "",
        overshoot_table(overshoot_rows(result, oracle))])
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "oracle.md").write_text(text + "\n")
    paths = [out_dir / "oracle.md", write_oracle_csv(bounds, out_dir / "oracle_bounds.csv"),
             write_oracle_csv(gaps, out_dir / "oracle_gaps.csv")]
    return text, paths
