"""`handover-study oracle-tune`, and the oracle's part of `handover-study bench`.

    handover-study oracle-tune                         # 1000 episodes of the tuning seed 1000
    handover-study bench -n 1000 --seed 1              # the bench reports the oracle gap by default
    handover-study bench --no-oracle                   # without it

`oracle-tune` tunes the sensor-only family of the oracle bound (`oracle_family`: scipy
differential evolution, globally and per behaviour class) on the tuning seed and writes
`services/studies/gripper/oracle_family_params.json`, which the benchmark reads.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import asdict
from pathlib import Path

from services.gripper.errors import GripperError
from services.runtime.cli import positive_int
from services.studies.engine_cli import engine_options
from services.studies.gripper.benchmark import TUNING_SEED, BenchResult
from services.studies.gripper.episodes import BEHAVIOUR_NAMES, EpisodeDistribution
from services.studies.gripper.oracle_family import PARAMS_PATH, TunedFamily, bench_chunks, tune
from services.studies.gripper.populations import POPULATIONS

DESCRIPTION = ("Tune the sensor-only family of the oracle bound (scipy differential evolution, globally and per "
               "behaviour class) on the tuning seed; the benchmark reads the result.")



def add_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `handover-study oracle-tune`."""
    p.add_argument("-n", "--episodes", type=positive_int, default=1000, help="tuning episodes")
    p.add_argument("--seed", type=int, default=TUNING_SEED, help="episode seed of the tuning set")
    p.add_argument("--chunk-size", type=positive_int, default=250, help="episodes per vectorised chunk")
    p.add_argument("--popsize", type=positive_int, default=4, help="differential evolution: members per parameter")
    p.add_argument("--maxiter", type=positive_int, default=12, help="differential evolution: generations")
    p.add_argument("--out", type=Path, default=PARAMS_PATH, help="where to write the tuned parameters (JSON)")
    p.add_argument("--log-level", default="warning", choices=["debug", "info", "warning", "error"])
    p.add_argument("--population", default="narrow", choices=sorted(POPULATIONS),
                   help="the episodes tuned on (the shipped parameters: narrow, the first benchmark's)")


def run(args: argparse.Namespace) -> int:
    """Tune the global member and one member per behaviour class; write them; exit code."""
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    t0 = time.perf_counter()
    chunks = bench_chunks(args.seed, args.episodes, args.chunk_size, args.population)
    settings = dict(popsize=args.popsize, maxiter=args.maxiter)
    try:
        best, summary = tune(chunks, **settings)
        print(f"global: {asdict(best)}  {summary}")
        cap = hi_overshoot_p95_n(chunks)
        capped, capped_summary = tune(chunks, overshoot_cap_n=cap, **settings)
        print(f"global, p95 overshoot <= HI's {cap:.2f} N: {asdict(capped)}  {capped_summary}")
        per_class, summaries = {}, {"global": summary, "global_capped": capped_summary}
        for code, label in BEHAVIOUR_NAMES.items():
            per_class[label], summaries[label] = tune(chunks, behaviour=code, **settings)
            print(f"{label}: {asdict(per_class[label])}  {summaries[label]}")
    except GripperError as exc:
        print(f"handover-study oracle-tune: error: {exc}", file=sys.stderr)
        return 2
    provenance = {"seed": args.seed, "episodes": args.episodes, "chunk_size": args.chunk_size, **settings,
                  "optimiser": "scipy.optimize.differential_evolution (tol=0, polish=False, seed=0)",
                  "wall_time_s": round(time.perf_counter() - t0, 1), "tuning": summaries}
    path = TunedFamily(best, capped, per_class, provenance).save(args.out)
    print(f"wrote {path} ({provenance['wall_time_s']} s)")
    return 0


def hi_overshoot_p95_n(chunks) -> float:
    """HI's p95 force overshoot over the taking episodes of `chunks` (the benchmark table's
    figure, same sensor noise), N: the cap of the capped family member."""
    import numpy as np

    from robot_sim.contact.episode import run_vectorised
    from services.gripper.controllers.registry import make_controller

    over = [run_vectorised(c.config, c.receivers, make_controller("HI", period_s=0.01), seed=s).force_overshoot_n[
        c.behaviour == 0] for c, s in chunks]
    return float(np.percentile(np.concatenate(over), 95))


# --------------------------------------------------------------------------- the bench's hook


def add_bench_arguments(p: argparse.ArgumentParser) -> None:
    """The oracle's flags of `handover-study bench`."""
    p.add_argument("--no-oracle", action="store_true",
                   help="skip the oracle bound (clairvoyant and sensor-only family; on by default; docs/gripper.md)")
    p.add_argument("--oracle-search", type=int, default=64, metavar="N",
                   help="random sequences the clairvoyant bound tries on each episode its family fails (0: none)")


def report_bench(args: argparse.Namespace, result: BenchResult, dist: EpisodeDistribution | None = None) -> None:
    """Compute the oracle bound on the benchmark's episodes, print it and write it to args.out."""
    if getattr(args, "no_oracle", False):
        return
    from services.studies.gripper.oracle_report import oracle_summary, run_oracle

    engine = engine_options(args, "oracle")
    oracle = run_oracle(result, args.episodes, chunk_size=args.chunk_size, dist=dist,
                        search=max(0, int(args.oracle_search)), **engine)
    text, paths = oracle_summary(result, oracle, args.out)
    print("\n" + text)
    for path in paths:
        print(f"wrote {path}")
