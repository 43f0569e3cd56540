"""`handover-study intent`: how well the wrist tells a taking receiver from the others, early.

    handover-study intent                                  # fit on seed 1000, test on seeds 1 and 2
    handover-study intent -n 960 --test-seeds 1 2 3 --model-out out/intent_model.json

Fits the logistic model of `services.studies.gripper.intent_study` on the tuning seed's
episodes and prints its accuracy per receiver kind on each held-out seed (markdown).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from services.gripper.errors import GripperError
from services.runtime.cli import positive_int
from services.studies.gripper.benchmark import TUNING_SEED
from services.studies.gripper.intent_features import LAGS_S
from services.studies.gripper.intent_study import accuracy_table, coefficients, collect, fit
from services.studies.gripper.oracle_family import bench_chunks
from services.studies.gripper.populations import DEFAULT_POPULATION, POPULATIONS

DESCRIPTION = ("Fit a logistic model of the receiver's intent (taking or not) on the wrist's first 100 ms after "
               "contact, on the tuning seed; report its accuracy per receiver kind on held-out seeds.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `handover-study intent`."""
    p.add_argument("-n", "--episodes", type=positive_int, default=960, help="episodes per seed")
    p.add_argument("--seed", type=int, default=TUNING_SEED, help="the training seed")
    p.add_argument("--test-seeds", type=int, nargs="+", default=[1, 2], help="held-out seeds")
    p.add_argument("--population", choices=sorted(POPULATIONS), default=DEFAULT_POPULATION)
    p.add_argument("--chunk-size", type=positive_int, default=240, help="episodes per vectorised chunk")
    p.add_argument("--model-out", type=Path, default=None, help="write the fitted model (JSON) here")


def run(args: argparse.Namespace) -> int:
    """Fit, test, print; exit code."""
    if args.seed in args.test_seeds:
        print(f"handover-study intent: error: test seed {args.seed} is the training seed", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    try:
        train = collect(bench_chunks(args.seed, args.episodes, args.chunk_size, args.population))
        model = fit(train, {"seed": args.seed, "episodes": args.episodes, "population": args.population})
        tables = {s: accuracy_table(model, collect(bench_chunks(s, args.episodes, args.chunk_size,
                                                                  args.population))) for s in args.test_seeds}
    except GripperError as exc:
        print(f"handover-study intent: error: {exc}", file=sys.stderr)
        return 1
    print(f"features at {', '.join(f'{1000 * lag:.0f}' for lag in LAGS_S)} ms after the contact onset; "
          f"trained on seed {args.seed} ({args.episodes} episodes, {args.population})")
    print("standardised weights (+: taking): " + ", ".join(f"{k} {v:+.2f}" for k, v in coefficients(model).items()))
    seeds = list(tables)
    print("\n| receiver kind | episodes per seed | " + " | ".join(f"classified taking %, seed {s}" for s in seeds)
          + " | " + " | ".join(f"accuracy %, seed {s}" for s in seeds) + " | onset after grasp start, median s |")
    print("|---|---|" + "---|" * (2 * len(seeds) + 1))
    first = tables[seeds[0]]
    for i, row in enumerate(first):
        taking = " | ".join(f"{100 * tables[s][i]['classified_taking']:.1f}" for s in seeds)
        acc = " | ".join(f"{100 * tables[s][i]['accuracy']:.1f}" for s in seeds)
        print(f"| {row['kind']} | {row['episodes']} | {taking} | {acc} | {row['onset_after_grasp_median_s']:.3f} |")
    if args.model_out:
        args.model_out.parent.mkdir(parents=True, exist_ok=True)
        print(f"wrote {model.save(args.model_out)}")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0
