"""`handover-contact`: the contact simulator's command line (`robot_sim.contact.cli`) with its
batches on the studies' engine (`services.studies.engine`, Dask): ``batch`` takes --workers
(the local cluster's size), --address (an existing cluster) and --checkpoint (resume).

    handover-contact batch --behaviour mixed -n 100000 --checkpoint out/contact_ckpt
    handover-contact batch -n 1000000 --address 10.0.0.5:8786 --json out/batch.json

Exit codes: 0 done, 1 the run failed (a chunk raised, the cluster unreachable), 2 bad input,
130 interrupted (the local cluster is torn down; the checkpoint keeps the finished chunks).
"""

from __future__ import annotations

import argparse
import sys

from robot_sim.contact import cli as contact_cli
from robot_sim.contact.batch import MapTasks
from services.studies.engine import available_cores, run_tasks
from services.studies.engine_cli import add_engine_arguments, engine_options
from services.studies.engine_errors import EngineError

__all__ = ["ENGINE", "main"]


class _Engine:
    """`robot_sim.contact.cli.BatchEngine` on `run_tasks`."""

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        add_engine_arguments(parser)

    def mapper(self, args: argparse.Namespace) -> tuple[MapTasks, int | None]:
        options = engine_options(args, "batch")
        options["description"] = f"{args.behaviour} episodes"
        workers = None if options["address"] else options["workers"] or available_cores()

        def map_tasks(function, tasks: list) -> list:
            return run_tasks(function, tasks, unit="ep", weights=[t.size for t in tasks], **options)

        return map_tasks, workers


ENGINE = _Engine()


def main(argv: list[str] | None = None) -> int:
    """Entry point of `handover-contact`; returns the exit code."""
    try:
        return contact_cli.main(argv, engine=ENGINE)
    except EngineError as exc:
        print(f"handover-contact: error: {exc}", file=sys.stderr)
        return 2 if exc.bad_input else 1


if __name__ == "__main__":
    sys.exit(main())
