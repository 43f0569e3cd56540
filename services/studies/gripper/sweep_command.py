"""`handover-study sweep`: a grid sweep of one or two parameters of a release controller on the
benchmark's episodes (the same episodes at every grid point), on the studies' engine.

    handover-study sweep --controller SG --param hold_per_weight=2:15:8 -n 2000
    handover-study sweep --controller SG-tuned-d3 --param hold_per_weight=2:15:8 \\
        --param max_hold_force_n=8:80:8 -n 16000 --workers 2 --checkpoint out/sweep_ckpt
    handover-study sweep --param release_share=0.2,0.3,0.5 -n 100000 --address 10.0.0.5:8786

Writes `--out`/sweep.csv (per grid point and reference: drops, failures and release success with
95 % Wilson intervals, overshoot median and p95 with the p95's interval, release time), table.md
and sweep.png (drops and p95 overshoot against the parameter, or heat maps for two), and with
`--doc` the page's `gripper-sweep` region. How the episodes are shared: `services.studies.gripper.sweep`.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from services.gripper.controllers.registry import CONTROLLER_NAMES
from services.gripper.errors import GripperError
from services.runtime.cli import positive_int
from services.studies.engine_cli import add_engine_arguments, engine_options
from services.studies.gripper.benchmark import TUNING_SEED
from services.studies.gripper.episodes import GRIPPER_CLASSES
from services.studies.gripper.populations import DEFAULT_POPULATION, POPULATIONS, population
from services.studies.gripper.sweep import run_sweep
from services.studies.gripper.sweep_grid import grid_points, parse_axis
from services.studies.gripper.sweep_report import check_region, markdown_table, rewrite_region, write_csv, write_plot

DESCRIPTION = "Grid sweep of one or two parameters of a release controller on the benchmark's episodes."


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Flags of `handover-study sweep`."""
    p.add_argument("--controller", default="SG", choices=CONTROLLER_NAMES, metavar="NAME",
                   help=f"the controller whose parameters are swept ({', '.join(CONTROLLER_NAMES)}); the others "
                        "keep its own values")
    p.add_argument("--param", action="append", default=[], required=True, metavar="SPEC",
                   help="a swept parameter, once or twice: NAME=LO:HI:N (log-spaced where the tuning's search box "
                        "says so, else linear), NAME=LO:HI:N:log, NAME=LO:HI:N:lin, or NAME=V1,V2,...")
    p.add_argument("-n", "--episodes", type=positive_int, default=2000,
                   help="episodes per grid point (the same episodes at every point)")
    p.add_argument("--seed", type=int, default=1,
                   help=f"episode seed (the tuned presets were tuned on seed {TUNING_SEED}: sweep on others)")
    p.add_argument("--population", choices=sorted(POPULATIONS), default=DEFAULT_POPULATION,
                   help="episode distribution (services/studies/gripper/populations.py)")
    p.add_argument("--grippers", nargs="+", choices=list(GRIPPER_CLASSES), default=None, metavar="CLASS",
                   help=f"gripper classes instead of the population's, equal shares ({', '.join(GRIPPER_CLASSES)})")
    p.add_argument("--chunk-size", type=positive_int, default=1000,
                   help="episodes per vectorised chunk (one engine task = one grid point × one chunk)")
    p.add_argument("--references", nargs="*", default=["HI"], choices=CONTROLLER_NAMES, metavar="NAME",
                   help="controllers also run on the same episodes (the swept controller with its own values "
                        "always is)")
    p.add_argument("--out", type=Path, default=Path("out/gripper_sweep"),
                   help="folder for sweep.csv, table.md and sweep.png")
    p.add_argument("--img-dir", type=Path, default=None, help="also write the plot here (e.g. docs/img)")
    p.add_argument("--doc", type=Path, default=None,
                   help="rewrite this page's gripper-sweep region with the table and the plot (e.g. docs/gripper.md)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plot")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_engine_arguments(p)


def _plot_name(controller: str, names: list[str]) -> str:
    return f"sweep_{controller}_{'_x_'.join(names)}.png".replace("/", "-")


def _command_line(args: argparse.Namespace) -> str:
    """The command that reproduces the sweep's figures (for the docs region's marker)."""
    words = ["handover-study sweep", f"--controller {args.controller}", *(f"--param {s}" for s in args.param),
             f"-n {args.episodes}", f"--seed {args.seed}", f"--population {args.population}"]
    if args.grippers:
        words.append("--grippers " + " ".join(args.grippers))
    words += [f"--chunk-size {args.chunk_size}", "--references " + " ".join(args.references), f"--doc {args.doc}"]
    return " ".join(words)


def run(args: argparse.Namespace) -> int:
    """Check the grid, run the sweep and write its reports; exit code (2 on bad input)."""
    try:
        axes = [parse_axis(spec, args.controller) for spec in args.param]
        points = grid_points(args.controller, axes)
        if args.doc is not None:
            check_region(args.doc)
        dist = population(args.population, args.grippers)
    except GripperError as exc:
        print(f"handover-study sweep: error: {exc}", file=sys.stderr)
        return 2
    engine = engine_options(args, "sweep")
    resumed = engine["checkpoint_path"] is not None and engine["checkpoint_path"].exists()
    try:
        result = run_sweep(args.controller, points, args.episodes, seed=args.seed, dist=dist,
                           population=args.population, chunk_size=args.chunk_size,
                           references=tuple(args.references), **engine)
    except KeyboardInterrupt:
        hint = "; run the same command to resume" if args.checkpoint else " (use --checkpoint DIR to resume one)"
        print(f"handover-study sweep: interrupted{hint}", file=sys.stderr)
        return 130
    total = args.episodes * (len(points) + len(result.references))
    table = markdown_table(result)
    print(f"\n{args.controller}: {len(points)} grid points + {len(result.references)} references × {args.episodes} "
          f"episodes = {total} episodes, population {args.population}, seed {args.seed}, "
          + (f"resumed from {engine['checkpoint_path']}, {result.wall_time_s:.1f} s for what was left\n" if resumed else
             f"{result.wall_time_s:.1f} s ({total / max(result.wall_time_s, 1e-9):.0f} episodes/s)\n"))
    print(table)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "table.md").write_text(table + "\n")
    written = [args.out / "table.md", write_csv(result, args.out / "sweep.csv")]
    image = None
    if not args.no_plot:
        log = tuple(a.log for a in axes)
        for folder in dict.fromkeys(d for d in (args.out, args.img_dir) if d is not None):
            image = write_plot(result, folder / _plot_name(args.controller, result.names), log)
            written.append(image)
    if args.doc is not None:
        body = (f"{args.controller}, {len(points)} grid points + references × {args.episodes} episodes "
                f"({total} in all), population {args.population}, seed {args.seed}. In bold: fewer drops than "
                f"{args.controller}'s own values (upper 95 % bound below its rate) with a p95 overshoot no "
                f"higher than HI's.\n\n{table}\n")
        if image is not None:
            body += f"\n![sweep]({os.path.relpath(image, args.doc.parent)})\n"
        written.append(rewrite_region(args.doc, body, _command_line(args)))
    for path in written:
        print(f"wrote {path}")
    return 0
