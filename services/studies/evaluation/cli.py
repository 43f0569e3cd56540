"""`handover-eval`: the whole-system evaluation (docs/evaluation.md).

    handover-eval run     --episodes N [--seed S] [--out DIR] [--workers W | --address HOST:PORT] [--resume]
    handover-eval report  --run DIR
    handover-eval replay  --run DIR --episode K [--open]

`run` draws N receivers and objects from the declared population (`population`), runs each
episode as a whole stack (`handover-up` in a subprocess with its own bus port, logins,
profile and recording folder) on the studies' engine (`services.studies.engine`: local Dask
workers by default, a cluster with ``--address``), writes one record per episode and the
report. An interrupted run continues with ``--resume``: finished episodes are not run again.

Exit codes: 0 done (failing episodes are results, listed in the report); 1 the run failed;
2 bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

from handover_model import robots
from services.runtime.cli import (HelpFormatter, bounded_int, bounded_seconds, one_line_parser, positive_int,
                                  run_subcommand)
from services.studies.evaluation.errors import EvaluationError

PROG = "handover-eval"
#: One whole stack uses about 0.6 core: the default runs one episode per two cores.
DEFAULT_WORKERS = max(1, (os.cpu_count() or 1) // 2)


#: `--seed`: any 63-bit seed; `--timeout-s`: the stack's stop after this long.
_non_negative_seed = bounded_int(0, 2**63 - 1)
_timeout = bounded_seconds(30.0, 3600.0)


def _add_run(sub: Any) -> None:
    p = sub.add_parser("run", help="run an evaluation (or continue one with --resume) and write its report",
                       description="Draw N episodes from the declared population, run each as a whole stack, "
                       "write a record per episode and the report (report/report.md in the run folder).",
                       formatter_class=HelpFormatter)
    p.add_argument("--episodes", type=positive_int, default=None,
                   help="episodes to run (required for a new run; with --resume: default the run's own)")
    p.add_argument("--seed", type=_non_negative_seed, default=None,
                   help="population seed: the same seed draws the same episodes (default 0; fixed by a resumed run)")
    p.add_argument("--out", type=Path, default=None,
                   help="the run's folder (default evaluations/eval-<start time>)")
    p.add_argument("--profile", default=None,
                   help="base deploy profile, a name under deploy/ or a TOML path (default sim; fixed by a resumed "
                        "run)")
    p.add_argument("--robot", choices=sorted(robots.BUILTIN), default=None,
                   help="the arm of every episode, with its built-in description (default: the base profile's "
                        "[robot] model; fixed by a resumed run); docs/robots.md")
    p.add_argument("--workers", type=positive_int, default=None,
                   help=f"episodes at once on this machine (default {DEFAULT_WORKERS}: one whole stack per two "
                        "cores); not with --address")
    p.add_argument("--address", default=None,
                   help="a Dask scheduler HOST:PORT to run the episodes on (its workers need this project and a "
                        "shared folder for --out)")
    p.add_argument("--timeout-s", type=_timeout, default=240.0,
                   help="an episode's stack is stopped after this long")
    p.add_argument("--clock", choices=["sim", "wall"], default=None,
                   help="sim (default for a new run): each episode on the simulation's clock, as fast as the "
                        "machine allows and the same episode again for the same seed (replays too); wall: real time")
    p.add_argument("--resume", action="store_true", help="continue the run in --out (episodes with a record are kept)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_run)


def _add_report(sub: Any) -> None:
    p = sub.add_parser("report", help="write the report of a run again from its records",
                       formatter_class=HelpFormatter)
    p.add_argument("--run", type=Path, required=True, help="the run's folder")
    p.set_defaults(func=_cmd_report)


def _add_replay(sub: Any) -> None:
    p = sub.add_parser("replay", help="run one episode of a run again and point to its recording",
                       description="Run the episode's stack again with its own profile and seed, on the run's clock "
                       "(the simulation clock: the same episode step for step; the wall clock: details can "
                       "differ) into <run>/replays/, print its outcome beside the original's and the command "
                       "that opens the new recording.", formatter_class=HelpFormatter)
    p.add_argument("--run", type=Path, required=True, help="the run's folder")
    p.add_argument("--episode", type=int, required=True, help="the episode (its number in the report)")
    p.add_argument("--open", action="store_true", help="open the new recording in the Rerun viewer (needs a display)")
    p.add_argument("--timeout-s", type=_timeout, default=240.0, help="the stack is stopped after this long")
    p.set_defaults(func=_cmd_replay)


def build_parser() -> argparse.ArgumentParser:
    parser = one_line_parser(prog=PROG, description="Whole-system evaluation of the handover stack in simulation: "
                             "a population of receivers and objects, one whole stack per episode, a report with "
                             "95 %% intervals and a replay command for every failing episode.",
                             epilog="`handover-eval COMMAND --help` lists a command's options; docs/evaluation.md "
                                    "explains the population, the records and the criteria.",
                             formatter_class=HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_run(sub)
    _add_report(sub)
    _add_replay(sub)
    return parser


def _cmd_run(args: argparse.Namespace) -> int:
    from services.studies.evaluation.run import RunOptions, run_evaluation

    if args.address is not None and args.workers is not None:
        raise EvaluationError("--workers and --address exclude each other: a cluster's workers are its own",
                              bad_input=True)
    out = args.out or Path("evaluations") / time.strftime("eval-%Y%m%d-%H%M%S")
    options = RunOptions(out=out, episodes=args.episodes, seed=args.seed, profile=args.profile,
                         workers=args.workers if args.address else (args.workers or DEFAULT_WORKERS),
                         address=args.address, timeout_s=args.timeout_s, resume=args.resume,
                         show_progress=not args.no_progress, clock=args.clock, robot=args.robot)
    report, headline = run_evaluation(options)
    for line in headline:
        print(line)
    print(f"report: {report}")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from services.studies.evaluation.run import report_again

    report, headline = report_again(args.run)
    for line in headline:
        print(line)
    print(f"report: {report}")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from services.studies.evaluation.replay import replay

    lines, recording = replay(args.run, args.episode, args.timeout_s)
    for line in lines:
        print(line)
    if args.open:
        import subprocess

        subprocess.Popen([sys.executable, "-m", "rerun", str(recording)], start_new_session=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of `handover-eval`; the exit code."""
    args = build_parser().parse_args(argv)
    hint = " (continue with --resume: finished episodes are kept)" if args.command == "run" else ""
    return run_subcommand(PROG, args, hint)


if __name__ == "__main__":
    raise SystemExit(main())
