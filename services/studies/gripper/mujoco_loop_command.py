"""`handover-study crosscheck-loop`: the release controllers closed-loop on both plants, our
contact plant and MuJoCo, over the benchmark's episodes with μ_k = μ_s on both
(`services.studies.gripper.mujoco_loop`; method and results in docs/contact.md, "Closed loop
on both plants").

    handover-study crosscheck-loop                                   # 48 narrow episodes, six controllers
    handover-study crosscheck-loop -n 300 --seed 1 --workers 2 --doc docs/contact.md --img-dir docs/img
    handover-study crosscheck-loop -n 300 --seed 1 --controllers SG --replay 17   # one episode, both plants

Writes table.md, summary.csv, episodes.csv and the plot to --out; with --doc the generated
region `crosscheck-loop-table` of that page. Exit 0 when done (disagreements between the plants
are results, not failures), 1 on a runtime failure, 2 on bad input.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

from services.gripper.controllers.registry import CONTROLLER_NAMES
from services.gripper.errors import GripperError
from services.runtime.cli import positive_int
from services.studies.engine_cli import add_engine_arguments, engine_options
from services.studies.gripper.benchmark import TUNING_SEED
from services.studies.gripper.populations import POPULATIONS, population

DESCRIPTION = "The release controllers closed-loop on our contact plant and on MuJoCo (μ_k = μ_s), same episodes."
DEFAULT_CONTROLLERS = ("FS1", "HI", "SG", "HI-tuned", "SG-tuned", "SG-tuned-d3")
_PROG = "handover-study crosscheck-loop"


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The closed-loop cross-check's flags."""
    p.add_argument("--controllers", nargs="+", default=list(DEFAULT_CONTROLLERS), metavar="NAME",
                   help=f"controllers to run on both plants (known: {', '.join(CONTROLLER_NAMES)})")
    p.add_argument("-n", "--episodes", type=positive_int, default=48, help="episodes per controller")
    p.add_argument("--seed", type=int, default=1,
                   help=f"episode seed, as `handover-study bench` (the presets were tuned on {TUNING_SEED})")
    p.add_argument("--population", choices=list(POPULATIONS), default="narrow",
                   help="episode distribution (services/studies/gripper/populations.py)")
    p.add_argument("--chunk-size", type=positive_int, default=250,
                   help="the benchmark's chunk size (episode i is the benchmark's episode i with the same value)")
    p.add_argument("--task-size", type=positive_int, default=25, help="episodes per engine task")
    p.add_argument("--out", type=Path, default=Path("out/crosscheck_loop"),
                   help="folder for table.md, summary.csv, episodes.csv and the plot")
    p.add_argument("--img-dir", type=Path, default=None, help="also write the plot here (e.g. docs/img)")
    p.add_argument("--doc", type=Path, default=None,
                   help="rewrite this page's crosscheck-loop-table region (e.g. docs/contact.md)")
    p.add_argument("--replay", type=int, default=None, metavar="INDEX",
                   help="run only episode INDEX of this run (0-based) on both plants and print its verdicts")
    p.add_argument("--no-plots", action="store_true", help="skip the plot")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_engine_arguments(p)


def _fail(message: str, code: int) -> int:
    print(f"{_PROG}: error: {message}", file=sys.stderr)
    return code


def _replay(args: argparse.Namespace, dist) -> int:
    from robot_sim.contact.crosscheck.closed_loop import run_mujoco_episode
    from robot_sim.contact.episode import run_episode
    from services.gripper.controllers.registry import make_controller
    from services.studies.gripper.episodes import RECEIVER_KINDS
    from services.studies.gripper.mujoco_loop import episode_spec

    spec = episode_spec(dist, args.episodes, args.chunk_size, args.seed, args.replay)
    o, r = spec.config.obj, spec.receiver
    print(f"episode {spec.index}: {RECEIVER_KINDS[spec.kind]}, mass {o.mass_kg:.3f} kg, μ {o.mu_static:.3f}, "
          f"pull angle {math.degrees(r.pull_angle_rad):.1f}°, gripper {spec.config.gripper.force_rate_n_per_s:g} N/s "
          f"at {spec.config.gripper.loop_rate_hz:g} Hz")
    for name in args.controllers:
        for plant, run in (("ours", run_episode), ("MuJoCo", run_mujoco_episode)):
            controller = make_controller(name, period_s=spec.config.control_period_s)
            out = run(spec.config, r, controller, seed=spec.seed).outcome
            print(f"  {name:<12} {plant:<7} dropped {out.dropped!s:<5} (at {out.drop_time_s:.3f} s)  handed over "
                  f"{out.handed_over!s:<5} released at {out.release_time_s:.3f} s  "
                  f"overshoot {out.force_overshoot_n:.2f} N  slip {1000 * out.slip_distance_m:.1f} mm")
    return 0


def _check(args: argparse.Namespace):
    """Everything a run needs, validated before any episode runs (GripperError otherwise)."""
    from robot_sim.contact.config import ContactSimError
    from robot_sim.contact.crosscheck.report import check_region
    from services.studies.gripper.mujoco_loop_report import REGION

    unknown = [c for c in args.controllers if c not in CONTROLLER_NAMES]
    if unknown:
        raise GripperError(f"unknown controller(s) {unknown}; choose from: {', '.join(CONTROLLER_NAMES)}")
    if args.replay is not None and not 0 <= args.replay < args.episodes:
        raise GripperError(f"--replay {args.replay} is not an episode of a run of -n {args.episodes} "
                           f"(0..{args.episodes - 1})")
    if args.doc is not None:
        try:
            check_region(args.doc, REGION)
        except ContactSimError as exc:
            raise GripperError(str(exc)) from None
    return population(args.population)


def run(args: argparse.Namespace) -> int:
    """Run both plants over the episodes and write the outputs (exit codes in the module docstring)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return _fail("the `mujoco` wheel is not installed (pip install mujoco, pinned in requirements.lock)", 1)
    from robot_sim.contact.config import ContactSimError
    from services.studies.engine import run_tasks
    from services.studies.engine_errors import EngineUsageError
    from services.studies.gripper.mujoco_loop import assemble, plan_tasks, run_task

    try:
        dist = _check(args)
        if args.replay is not None:
            return _replay(args, dist)
        tasks = plan_tasks(list(args.controllers), dist, args.episodes, args.seed, args.chunk_size, args.task_size)
        engine = engine_options(args, "crosscheck_loop")
        results = run_tasks(run_task, tasks, description="both plants", unit="ep",
                            weights=[t.stop - t.start for t in tasks], **engine)
    except (GripperError, EngineUsageError) as exc:
        return _fail(str(exc), 2)
    except ContactSimError as exc:
        return _fail(str(exc), 1)
    if args.seed == TUNING_SEED:
        print(f"note: seed {TUNING_SEED} is the presets' tuning seed; held-out figures need another seed")
    return _write(args, assemble(results, args.seed, args.population))


def _write(args: argparse.Namespace, result) -> int:
    from robot_sim.contact.crosscheck.report import rewrite_region
    from services.studies.gripper.mujoco_loop_report import (PLOT_NAME, REGION, doc_region, flip_lines, flips_table,
                                                             mcnemar_lines, summary_table, write_csv,
                                                             write_episodes_csv, write_plot)
    from services.studies.gripper.mujoco_loop_stats import flips, mcnemar_rows, plant_stats

    rows, flip_rows, tests = plant_stats(result), flips(result), mcnemar_rows(result)
    table = summary_table(rows)
    print(f"\n{result.episodes} episodes per controller, population {result.population}, seed {result.seed}; "
          f"MuJoCo {result.episodes_per_s('mujoco'):.1f} episodes/s, ours {result.episodes_per_s('ours'):.1f} "
          "episodes/s (per worker)\n")
    print(table + "\n\nflips (ours-only drops / MuJoCo-only drops / handover flips (episodes)):\n\n"
          + flips_table(flip_rows))
    for line in mcnemar_lines(tests) + flip_lines(flip_rows):
        print(line)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    (out / "table.md").write_text(doc_region(result, rows, flip_rows, tests, _command_line(args)) + "\n")
    written = [out / "table.md", write_csv(rows, out / "summary.csv"), write_episodes_csv(result, out / "episodes.csv")]
    with (out / "mcnemar.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(tests[0]))
        w.writeheader()
        w.writerows(tests)
    written.append(out / "mcnemar.csv")
    if not args.no_plots:
        written += [write_plot(result, rows, d / PLOT_NAME) for d in dict.fromkeys(x for x in (out, args.img_dir) if x)]
    if args.doc is not None:
        written.append(rewrite_region(args.doc, doc_region(result, rows, flip_rows, tests, _command_line(args)),
                                      _command_line(args), REGION))
    for path in written:
        print(f"wrote {path}")
    return 0


def _command_line(args: argparse.Namespace) -> str:
    return (f"handover-study crosscheck-loop -n {args.episodes} --seed {args.seed} --population {args.population} "
            f"--controllers {' '.join(args.controllers)}")
