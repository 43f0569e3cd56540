"""`handover-study`: the offline studies of the stack, one command line.

    handover-study bench       Monte-Carlo benchmark of the gripper's release controllers
    handover-study oracle-tune tune the sensor-only family of the benchmark's oracle bound
    handover-study tune        tune a release controller's parameters (CMA-ES) into a preset
    handover-study sweep       grid sweep of one or two of a release controller's parameters
    handover-study intent      how well the wrist tells a taking receiver from the others, early
    handover-study reproduce   thesis Figures 20-23 and their comparison table
    handover-study failsafe    the fail-safe law's thresholds: fst | fbt | conditions
    handover-study figures     the docs pages' figures: motion | planner | gripper | all
    handover-study experiment  candidate transfer positions of the thesis's experiment
    handover-study record      one simulated tracker episode to a replay file
    handover-study evaluate    the tracker's hand error against the simulator's truth
    handover-study tracker-defaults  the tracker configuration to ship, chosen and confirmed on other seeds
    handover-study crosscheck  the contact plant against MuJoCo, scenario by scenario
    handover-study crosscheck-loop  the release controllers closed-loop on both plants

None of them needs the bus or a running stack. Exit codes: 0 done, 1 a failure while running,
2 bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable
from types import ModuleType

from services.runtime.cli import HelpFormatter, one_line_parser, run_subcommand

PROG = "handover-study"


def _commands() -> list[tuple[str, str, Callable[[argparse.ArgumentParser], None], Callable]]:
    """(name, description, add_arguments, run) of every study command."""
    from services.studies import crosscheck_command, figures_command
    from services.studies.gripper import (analysis_command, bench_command, intent_command, mujoco_loop_command,
                                          oracle_command, reproduce_command, sweep_command, tune_command)
    from services.studies.planner import experiment_command
    from services.studies.tracker import commands as tracker

    modules: list[tuple[str, ModuleType]] = [
        ("bench", bench_command), ("oracle-tune", oracle_command), ("tune", tune_command), ("sweep", sweep_command),
        ("intent", intent_command),
        ("reproduce", reproduce_command),
        ("failsafe", analysis_command), ("figures", figures_command), ("experiment", experiment_command),
        ("crosscheck", crosscheck_command), ("crosscheck-loop", mujoco_loop_command),
    ]
    table = [(name, module.DESCRIPTION, module.add_arguments, module.run) for name, module in modules]
    table.append(("record", tracker.RECORD_DESCRIPTION, tracker.add_record_arguments, tracker.run_record))
    table.append(("evaluate", tracker.EVALUATE_DESCRIPTION, tracker.add_evaluate_arguments, tracker.run_evaluate))
    table.append(("tracker-defaults", tracker.DEFAULTS_DESCRIPTION, tracker.add_defaults_arguments,
                  tracker.run_defaults))
    return table


def build_parser() -> argparse.ArgumentParser:
    """The `handover-study` parser with one sub-command per study."""
    parser = one_line_parser(prog=PROG, description="The stack's offline studies: benchmarks, thesis "
                             "reproductions, figures and evaluations. None of them needs the bus.",
                             epilog="`handover-study COMMAND --help` lists a command's flags.",
                             formatter_class=HelpFormatter)
    parser.set_defaults(log_level="warning")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, description, add_arguments, run in _commands():
        command = sub.add_parser(name, help=description, description=description, formatter_class=HelpFormatter)
        add_arguments(command)
        command.set_defaults(func=run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of `handover-study`; returns the exit code."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    return run_subcommand(PROG, args)
