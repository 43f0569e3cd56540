"""`handover-study figures`: the figures of the docs pages, written from real runs of the models.

    handover-study figures [motion|planner|gripper|all] [--out docs/img]

- motion: transfers with and without the receiver-zone cap, a stop mid-reach (docs/motion.md);
- planner: thesis Figure 3's case, the findings, the robot as the giver (docs/planner.md);
- gripper: thesis Figures 18 and 19, the fail-safe law's thresholds (docs/gripper.md).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

DESCRIPTION = "Write the figures of the docs pages (PNG) from real runs of the models."


def _motion(out: Path) -> list[Path]:
    from services.studies.motion.figures import make_docs_figures

    return make_docs_figures(out)


def _planner(out: Path) -> list[Path]:
    from services.studies.planner.figures import figure3, findings, robot

    plan = figure3(out)
    findings(out)
    robot(out)
    x, z = plan.position_task_m
    print(f"Figure 3 case optimum: x = {x * 100:+.1f} cm, z = {z * 100:.1f} cm above the table")
    return [out / f"planner_{name}.png" for name in ("figure3", "findings", "robot")]


def _gripper(out: Path) -> list[Path]:
    from services.studies.gripper.analysis_command import make_figures

    return make_figures(out)


FIGURE_SETS: dict[str, Callable[[Path], list[Path]]] = {
    "motion": _motion, "planner": _planner, "gripper": _gripper,
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Which figures and where."""
    p.add_argument("which", nargs="?", default="all", choices=[*FIGURE_SETS, "all"],
                   help="which page's figures (default: all)")
    p.add_argument("--out", type=Path, default=Path("docs/img"), help="output folder (default: docs/img)")


def run(args: argparse.Namespace) -> int:
    """Write the chosen figures and print each file written."""
    if args.out.exists() and not args.out.is_dir():
        print(f"handover-study figures: error: {args.out} is not a folder", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    names = list(FIGURE_SETS) if args.which == "all" else [args.which]
    for name in names:
        for path in FIGURE_SETS[name](args.out):
            print(f"wrote {path}")
    return 0
