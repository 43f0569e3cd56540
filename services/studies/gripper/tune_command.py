"""`handover-study tune`: tune a release controller's parameters with CMA-ES on the tuning seed.

    handover-study tune --controller SG --episodes 960 --seed 1000 --budget 200
    handover-study tune --controller SG --resume                  # go on from out/tune_SG.json
    handover-study tune --controller HI --budget 60 --write-preset HI-tuned
    handover-study tune --controller SG --budget 400 --address 10.0.0.5:8786   # on a Dask cluster

The objective and its weights: `services.studies.gripper.tuning` (failures, p95 overshoot, release
time, and a penalty above HI's p95 overshoot). The best-so-far is written to `--out` after every
generation (Ctrl-C loses at most the generation in flight); `--write-preset NAME` stores the
result as a controller preset (`services/gripper/controllers/tuned_presets.json`) that the
benchmark and the gripper service can run by name (`handover-study bench --controllers NAME`).

Each generation's chunks run on the studies' engine (`services.studies.engine`): a local Dask
cluster of every core kept for the whole run (`--workers N`; `--workers 1` runs them in this
process), or an existing cluster (`--address HOST:PORT`). A task is one chunk's batch of all the
generation's sets, the same batch wherever it runs, so the scores do not depend on where it ran.
On this 2-core machine a generation takes 0.56× the in-process time for 1.3 s of cluster start-up
(`tests/bench/test_bench_tune_engine.py`; docs/gripper.md, "Sweeps at scale").
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from tqdm import tqdm

from services.gripper.controllers.tuned import PRESETS_PATH, save_preset
from services.gripper.errors import GripperError
from services.runtime.cli import bounded_float, positive_int
from services.studies.gripper.benchmark import TUNING_SEED
from services.studies.gripper.oracle_family import bench_chunks
from services.studies.gripper.populations import DEFAULT_POPULATION, POPULATIONS
from services.studies.gripper.tune_cma import run_cma, state_path
from services.studies.engine import open_cluster
from services.studies.engine_cli import add_engine_arguments
from services.studies.gripper.tuning import OBJECTIVE_WEIGHTS, SPACES, Runner, engine_runner, hi_p95_n

DESCRIPTION = "Tune a release controller's parameters with CMA-ES on the tuning seed; write the best as a preset."


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `handover-study tune`."""
    p.add_argument("--controller", required=True, choices=sorted(SPACES), help="the controller whose parameters "
                   "are searched (the search box per controller: services/studies/gripper/tuning.py SPACES)")
    p.add_argument("-n", "--episodes", type=positive_int, default=960, help="tuning episodes (same for every "
                   "parameter set; a multiple of 24 keeps the wide population's 24 sub-populations equal)")
    p.add_argument("--seed", type=int, default=TUNING_SEED, help="episode seed of the tuning set (evaluate on others)")
    p.add_argument("--population", choices=sorted(POPULATIONS), default=DEFAULT_POPULATION,
                   help="episode distribution tuned on")
    p.add_argument("--budget", type=positive_int, default=200, help="parameter sets to evaluate in all")
    p.add_argument("--popsize", type=positive_int, default=None, help="CMA-ES generation size (default: cma's "
                   "4 + 3 ln d)")
    p.add_argument("--chunk-size", type=positive_int, default=240, help="episodes per vectorised chunk")
    p.add_argument("--out", type=Path, default=None, help="best-so-far JSON, rewritten every generation "
                   "(default out/tune_CONTROLLER.json; the optimiser's state goes next to it as .cma.pkl)")
    p.add_argument("--resume", action="store_true", help="go on from --out and its .cma.pkl (same episodes)")
    p.add_argument("--write-preset", metavar="NAME", default=None, help="store the best parameters as controller "
                   f"preset NAME in {PRESETS_PATH.name} (e.g. SG-tuned)")
    p.add_argument("--presets-file", type=Path, default=PRESETS_PATH, help="the presets file --write-preset writes")
    p.add_argument("--drop-weight", type=bounded_float(1.0, 100.0), default=1.0,
                   help="a dropped object counts this many failures in the objective (1–100; 1: like a refused "
                        "handover; keep it on --resume)")
    p.add_argument("--above-hi-weight", type=bounded_float(0.0, 100.0), default=OBJECTIVE_WEIGHTS["above_hi_per_n"],
                   metavar="PER_N", help="objective weight of each N of p95 overshoot above HI's on the tuning "
                   "episodes (0–100 per N; 1 makes 1 N above HI cost as much as every episode failing; keep it "
                   "on --resume)")
    p.add_argument("--p95-margin", type=bounded_float(0.0, 20.0, " N"), default=0.0, metavar="N",
                   help="the objective's p95 hinge starts this far below HI's p95 overshoot on the tuning episodes "
                        "(0–20 N): room for the spread of a p95 on held-out seeds; keep it on --resume")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_engine_arguments(p, checkpoint=False)


def run(args: argparse.Namespace) -> int:
    """Tune, write the JSON after every generation, and optionally the preset; exit code."""
    out = args.out or Path("out") / f"tune_{args.controller}.json"
    if args.resume and not (out.exists() and state_path(out).exists()):
        print(f"handover-study tune: error: --resume needs {out} and {state_path(out)} from an earlier run",
              file=sys.stderr)
        return 2
    with open_cluster(args.address, args.workers) as client:  # None for --workers 1: in this process
        return _tune(args, out, engine_runner(client))


def _tune(args: argparse.Namespace, out: Path, runner: Runner) -> int:
    """The tuning run (`runner`: where the chunks run, `tuning.evaluate`); exit code."""
    space = SPACES[args.controller]
    t0 = time.perf_counter()
    chunks = bench_chunks(args.seed, args.episodes, args.chunk_size, args.population)
    hi = hi_p95_n(chunks, runner) - args.p95_margin  # the hinge's reference: HI's p95, less the margin
    provenance = {"seed": args.seed, "episodes": args.episodes, "population": args.population,
                  "chunk_size": args.chunk_size, "budget": args.budget, "popsize": args.popsize,
                  "optimiser": "cma.CMAEvolutionStrategy (cma 4.5.0, unit-cube bounds, sigma0 0.25, seed 1)",
                  "objective": "failure rate + w · (p95 overshoot, median release time, p95 above HI's)",
                  "weights": {**OBJECTIVE_WEIGHTS, "above_hi_per_n": args.above_hi_weight},
                  "drop_weight": args.drop_weight, "p95_margin_n": args.p95_margin,
                  "space": {k: list(v) for k, v in space.bounds.items()}}
    bar = tqdm(total=args.budget, unit="set", desc=f"tune {args.controller}", disable=args.quiet,
               dynamic_ncols=True)

    def progress(state) -> None:
        bar.n = min(state.evaluations, args.budget)
        b = state.best
        bar.set_postfix_str(f"J {b['objective']:.4f} fail {100 * b['failure_rate']:.1f}% "
                            f"p95 {b['overshoot_p95_n']:.1f} N")
        bar.refresh()

    interrupted = False
    try:
        state = run_cma(space, chunks, args.budget, out, hi, provenance, resume=args.resume, popsize=args.popsize,
                        on_generation=progress, drop_weight=args.drop_weight,
                        above_hi_per_n=args.above_hi_weight, runner=runner)
    except KeyboardInterrupt:
        interrupted = True
    except GripperError as exc:
        bar.close()
        print(f"handover-study tune: error: {exc}", file=sys.stderr)
        return 1
    bar.close()
    if interrupted:
        print(f"interrupted: the best so far (last full generation) is in {out}; `--resume` goes on from there",
              file=sys.stderr)
        return 130
    s, b = state.start, state.best_rerun or state.best
    reference = f"HI's p95 − {args.p95_margin:g} N" if args.p95_margin else "HI's"
    print(f"{args.controller}: start J {s['objective']:.4f} (failures {100 * s['failure_rate']:.1f} %, "
          f"p95 {s['overshoot_p95_n']:.2f} N) → best J {b['objective']:.4f} (failures "
          f"{100 * b['failure_rate']:.1f} %, drops {100 * b['drop_rate']:.1f} %, p95 {b['overshoot_p95_n']:.2f} N, "
          f"{reference}: {hi:.2f} N, release {b['release_time_median_s']:.3f} s; re-run alone) after "
          f"{state.evaluations} sets, {time.perf_counter() - t0:.0f} s")
    print("best parameters: " + ", ".join(f"{k}={v:.4g}" for k, v in state.best_params.items()))
    print(f"wrote {out}")
    if args.write_preset:
        try:
            path = save_preset(args.write_preset, args.controller, state.best_params,
                               {**provenance, "tuning": b, "start": s, "evaluations": state.evaluations},
                               args.presets_file)
        except GripperError as exc:
            print(f"handover-study tune: error: {exc}", file=sys.stderr)
            return 1
        print(f"wrote preset {args.write_preset} to {path}")
    return 0
