"""Command line that writes the DJT planner figures (PNG):
``python -m services.planner.figures --out docs/img``."""

from __future__ import annotations

from pathlib import Path

from services.planner.figures import figure3, findings, robot
from services.runtime.cli import one_line_parser


def main(argv: list[str] | None = None) -> int:
    parser = one_line_parser(prog="python -m services.planner.figures",
                                     description="Write the DJT planner figures (PNG): Figure 3 case, "
                                                 "findings, the robot as a receiver.")
    parser.add_argument("--out", type=Path, default=Path("docs/img"), help="output folder (default: docs/img)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    plan = figure3(args.out)
    findings(args.out)
    robot(args.out)
    x, z = plan.position_task_m
    print(f"Figure 3 case optimum: x = {x * 100:+.1f} cm, z = {z * 100:.1f} cm above the table")
    print(f"figures written to {args.out}/planner_{{figure3,findings,robot}}.png")
    return 0
