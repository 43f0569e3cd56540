"""`handover-study bench`: the Monte-Carlo benchmark of the gripper's release controllers
(`services.studies.gripper.benchmark` runs the episodes and computes the statistics,
`services.studies.gripper.bench_report` writes the tables and plots).

    handover-study bench                                     # CI-sized: 200 episodes each, "wide" population
    handover-study bench --population narrow -n 10000 --seed 1   # the first benchmark's distribution
    handover-study bench -n 12000 --controllers FS1 HI SG --workers 2   # 500 per sub-population of "wide"
    handover-study bench -n 5000 --seed 1 --controllers FS1 HI SG --attribute --out out/gripper_bench_v2
    handover-study bench -n 10000 --seed 1000 --controllers HI SG --set SG:max_hold_force_n=18 --attribute
    handover-study bench -n 100000 --controllers SG --checkpoint out/bench_ckpt   # rerun it to resume
    handover-study bench -n 1000000 --controllers SG --address 10.0.0.5:8786     # on a Dask cluster
"""

from __future__ import annotations

import argparse
import csv
import logging
import sys
from pathlib import Path

from services.gripper.controllers.registry import CONTROLLER_NAMES, make_controller
from services.gripper.errors import GripperError
from services.runtime.cli import positive_int
from services.studies.engine_cli import add_engine_arguments, engine_options
from services.studies.gripper import oracle_command
from services.studies.gripper.bench_report import (
    attribution_table,
    gripper_table,
    paired_lines,
    markdown_table,
    subpopulation_table,
    write_csv,
    write_plots,
    write_subpopulation_csv,
    write_subpopulation_plot,
)
from services.studies.gripper.benchmark import (
    DEFAULT_CONTROLLERS,
    REFERENCES,
    TUNING_SEED,
    drop_attribution,
    per_gripper_paired_tests,
    per_gripper_stats,
    paired_drop_test,
    paired_overshoot_rows,
    run_benchmark,
    subpopulation_stats,
    summarise,
)
from services.studies.gripper.episodes import GRIPPER_CLASSES
from services.studies.gripper.populations import DEFAULT_POPULATION, POPULATIONS, population


def _override(text: str) -> tuple[str, str, float | bool]:
    """`CONTROLLER:PARAM=VALUE` → (controller, param, value); VALUE a number, true or false."""
    try:
        name, rest = text.split(":", 1)
        key, raw = rest.split("=", 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected CONTROLLER:PARAM=VALUE, e.g. SG:share_cap=1") from None
    low = raw.strip().lower()
    if low in ("true", "false"):
        return name, key, low == "true"
    try:
        return name, key, float(raw)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: VALUE must be a number, true or false") from None


DESCRIPTION = "Monte-Carlo benchmark of the gripper's release controllers on the realistic contact plant."


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The benchmark's flags."""
    p.add_argument("--controllers", nargs="+", default=list(DEFAULT_CONTROLLERS), metavar="NAME",
                   help=f"controllers to compare (known: {', '.join(CONTROLLER_NAMES)})")
    p.add_argument("-n", "--episodes", type=positive_int, default=200, help="episodes per controller")
    p.add_argument("--seed", type=int, default=1,
                   help=f"episode seed (the SG controller was tuned on seed {TUNING_SEED}: evaluate on others)")
    p.add_argument("--population", choices=list(POPULATIONS), default=DEFAULT_POPULATION,
                   help="episode distribution: wide (default: six receiver kinds, including the taking receivers who "
                        "pull before or without lifting, × four gripper classes, stratified) or narrow (the first "
                        "benchmark's: reproduces its figures); see services/studies/gripper/populations.py")
    p.add_argument("--grippers", nargs="+", choices=list(GRIPPER_CLASSES), default=None, metavar="CLASS",
                   help=f"gripper classes instead of the population's, equal shares ({', '.join(GRIPPER_CLASSES)})")
    p.add_argument("--chunk-size", type=positive_int, default=250, help="episodes per vectorised chunk")
    p.add_argument("--out", type=Path, default=Path("out/gripper_bench"),
                   help="folder for table.md, results.csv, plots")
    p.add_argument("--img-dir", type=Path, default=None, help="also write the plots here (e.g. docs/img)")
    p.add_argument("--attribute", action="store_true",
                   help="also run the max-hold and reactive-max-hold references and attribute every drop "
                        "(unavoidable, actuator-limited, receiver let go, controller); paired overshoot, with "
                        "bootstrap intervals, against --against")
    p.add_argument("--against", default=None, metavar="NAME",
                   help="the controller the paired tests compare every other one with: McNemar on the drops, and "
                        "with --attribute the paired overshoot (one of --controllers; default SG, when it runs)")
    p.add_argument("--set", dest="overrides", type=_override, action="append", default=[],
                   metavar="CONTROLLER:PARAM=VALUE",
                   help="override one parameter of one controller (repeatable), e.g. SG:hold_per_weight=5")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--log-level", default="warning", choices=["debug", "info", "warning", "error"])
    oracle_command.add_bench_arguments(p)
    add_engine_arguments(p)


def _paired_drop_tests(result, against: str = "SG") -> list[dict]:
    """McNemar's exact test of `against` and every other controller (printed), if `against` ran."""
    tests = []
    if against in result.outcomes:
        for other in result.outcomes:
            if other != against and other not in REFERENCES:
                t = paired_drop_test(result, against, other)
                tests.append(t)
                p_text = f"= {t['p_value']:.2g}" if t["p_value"] > 0 else "< 1e-300"  # below the double range
                print(f"paired drops {against} vs {other}: {against}-only {t['only_a_drops']}, {other}-only "
                      f"{t['only_b_drops']}, McNemar exact p {p_text}")
    return tests


def _paired_overshoot(result, against: str, csv_path: Path) -> None:
    """Print the paired overshoot of `against` and every other controller (bootstrap CIs) and
    write it to `csv_path`."""
    rows = [r for r in paired_overshoot_rows(result, against) if r.get("episodes")]
    print("\nForce overshoot on the taking episodes both handed over (N):")
    for r in rows:
        print(f"{against} vs {r['other']}: {r['episodes']} episodes, median {r['a_median_n']:.2f} vs "
              f"{r['b_median_n']:.2f}, p95 {r['a_p95_n']:.2f} vs {r['b_p95_n']:.2f}, "
              f"median paired difference {r['median_difference_n']:+.2f}")
        for label, what in (("handed_over", "both handed over"), ("all_taking", "all taking")):
            cells = []
            for stat in ("median", "p95"):
                lo, hi = r[f"{stat}_diff_{label}_ci_n"]
                cells.append(f"{stat} {r[f'{stat}_diff_{label}_n']:+.2f} [{lo:+.2f}, {hi:+.2f}]")
            print(f"    {against} − {r['other']} on {what}: " + ", ".join(cells) + " N (paired bootstrap 95 % CI)")
    flat = [{"against": against, **{k: (f"{v[0]:.4f};{v[1]:.4f}" if isinstance(v, tuple) else v)
                                    for k, v in r.items()}} for r in rows]
    with csv_path.open("w", newline="") as fh:
        if flat:
            w = csv.DictWriter(fh, fieldnames=list(flat[0]))
            w.writeheader()
            w.writerows(flat)


def _by_gripper(result, n_controllers: int) -> str:
    """The per-gripper table and paired tests when the run had more than one gripper class."""
    per_gripper = per_gripper_stats(result)
    if len(per_gripper) <= n_controllers:
        return ""
    return ("\n\nPer gripper (every receiver kind; in bold the gripper's best controller: fewest drops, "
            "then more handovers):\n\n" + gripper_table(per_gripper)
            + "\n\nPaired drops on each gripper's episodes:\n\n" + paired_lines(per_gripper_paired_tests(result)))


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and write its tables and plots; returns the exit code (2 on bad input)."""
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    overrides: dict[str, dict] = {}
    for name, key, value in args.overrides:
        overrides.setdefault(name, {})[key] = value
    try:
        if args.against is not None and args.against not in args.controllers:
            raise GripperError(f"--against {args.against} is not in --controllers {args.controllers}")
        args.against = args.against or "SG"
        unknown = sorted(set(overrides) - set(args.controllers))
        if unknown:
            raise GripperError(f"--set names controller(s) {unknown} that are not in --controllers {args.controllers}")
        for name, params in overrides.items():
            make_controller(name, **params)  # refuse an unknown parameter before any episode runs
        dist = population(args.population, args.grippers)
        engine = engine_options(args, "bench")
        result = run_benchmark(args.controllers, args.episodes, seed=args.seed, chunk_size=args.chunk_size,
                               progress=engine.pop("show_progress"), attribute=args.attribute, overrides=overrides,
                               dist=dist, **engine)
    except GripperError as exc:
        print(f"handover-study bench: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("handover-study bench: interrupted", file=sys.stderr)
        return 130
    rows, sub_rows = summarise(result), subpopulation_stats(result)
    grippers = "" if args.grippers is None else f" with grippers {' '.join(args.grippers)}"
    table = (markdown_table(rows) + _by_gripper(result, len(rows))
             + "\n\nPer sub-population (receiver kind × gripper class; handovers, objects held to the end, "
             "release success, overshoot and release time over the taking receivers):\n\n"
             + subpopulation_table(sub_rows))
    print(f"\n{args.episodes} episodes per controller, population {args.population}{grippers}, seed {args.seed}, "
          f"{result.wall_time_s:.1f} s\n")
    print(table)
    tests = _paired_drop_tests(result, args.against)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.attribute:
        att = drop_attribution(result)
        att_table = attribution_table(att)
        print("\nWho dropped it (% of all episodes; see services/studies/gripper/attribution.py)\n")
        print(att_table)
        (args.out / "attribution.md").write_text(att_table + "\n")
        if args.against in result.outcomes:
            _paired_overshoot(result, args.against, args.out / "paired_overshoot.csv")
    (args.out / "table.md").write_text(table + "\n")
    print(f"\nwrote {args.out / 'table.md'}")
    print(f"wrote {write_csv(rows, args.out / 'results.csv')}")
    print(f"wrote {write_subpopulation_csv(sub_rows, args.out / 'subpopulations.csv')}")
    if tests:
        with (args.out / "paired.csv").open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(tests[0]))
            w.writeheader()
            w.writerows(tests)
    if not args.no_plots:
        for d in {args.out, args.img_dir} - {None}:
            for path in write_plots(result, rows, d) + [write_subpopulation_plot(sub_rows, d)]:
                print(f"wrote {path}")
    try:
        oracle_command.report_bench(args, result)
    except GripperError as exc:
        print(f"handover-study bench: error: {exc}", file=sys.stderr)
        return 2
    return 0
