"""The engine's command-line flags, the same in every command that runs on it
(`handover-study bench`, `handover-contact batch`, …): ``--workers``, ``--address``,
``--checkpoint``; and `engine_options`, which turns them into `run_tasks` keywords."""

from __future__ import annotations

import argparse
from pathlib import Path

from services.runtime.cli import positive_int
from services.studies.engine import normalise_address
from services.studies.engine_errors import EngineUsageError

__all__ = ["add_engine_arguments", "engine_options"]


def _address(text: str) -> str:
    """argparse type of ``--address``: a one-line usage error (exit 2) for a malformed one."""
    try:
        normalise_address(text)
    except EngineUsageError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--address ")) from None
    return text


def add_engine_arguments(parser: argparse.ArgumentParser, checkpoint: bool = True) -> None:
    """Add ``--workers``, ``--address`` and (unless `checkpoint` is False: a command with its own
    resume) ``--checkpoint``, in their own group."""
    group = parser.add_argument_group("engine (Dask; docs/engine.md)")
    where = group.add_mutually_exclusive_group()
    where.add_argument("--workers", type=positive_int, default=None, metavar="N",
                       help="worker processes of the local cluster started for the run (default: every core; "
                            "1 runs everything in this process)")
    where.add_argument("--address", type=_address, default=None, metavar="HOST:PORT",
                       help="run on an existing Dask cluster, e.g. 10.0.0.5:8786 (`dask scheduler` prints it; "
                            "every worker needs this project installed); default: a local cluster on 127.0.0.1")
    if not checkpoint:
        return
    group.add_argument("--checkpoint", type=Path, default=None, metavar="DIR",
                       help="keep every finished chunk in DIR as it finishes; run the same command again to "
                            "continue an interrupted run where it stopped (other arguments are refused)")


def engine_options(args: argparse.Namespace, phase: str) -> dict:
    """`run_tasks` keywords from the flags: address, workers and the checkpoint file of
    `phase` (one file per phase of a command, e.g. ``bench`` and ``oracle``, in --checkpoint)."""
    folder = getattr(args, "checkpoint", None)
    return {"address": getattr(args, "address", None), "workers": getattr(args, "workers", None),
            "checkpoint_path": None if folder is None else Path(folder) / f"{phase}.ckpt",
            "show_progress": not getattr(args, "no_progress", False)}
