"""`handover-study reproduce`: the thesis's Figures 20–23 in the thesis model mode and the table
that compares them with the thesis's statements.

    handover-study reproduce [--preset P] [--img-dir D] [--rrd-dir D] [--table F]
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from services.gripper.errors import GripperError
from services.studies.gripper.claims import claims_table
from services.studies.gripper.reproduce import PRESET_TAGS, reproduce

DESCRIPTION = "Reproduce thesis Figures 20-23 (thesis model mode) and compare them with the thesis's statements."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The reproduction's flags."""
    parser.add_argument("--preset", action="append", choices=sorted(PRESET_TAGS),
                        help="fail-safe parameter set (repeatable; default: FS-sim-g5 and FS-sim-g1)")
    parser.add_argument("--img-dir", type=Path, default=Path("docs/img"), help="where PNGs go (default docs/img)")
    parser.add_argument("--rrd-dir", type=Path, default=Path("out/reproduction"), help="where .rrd files go")
    parser.add_argument("--table", type=Path, default=Path("out/reproduction/table.md"), help="Markdown table output")
    parser.add_argument("--no-images", action="store_true", help="skip PNGs")
    parser.add_argument("--no-rrd", action="store_true", help="skip Rerun recordings")


def run(args: argparse.Namespace) -> int:
    """Run the reproduction, print the table and the files written; exit 1 on a failure."""
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    presets = args.preset or ["FS-sim-g5", "FS-sim-g1"]
    try:
        claims, written = reproduce(presets, None if args.no_images else args.img_dir,
                                    None if args.no_rrd else args.rrd_dir)
        table = claims_table(claims)
        args.table.parent.mkdir(parents=True, exist_ok=True)
        args.table.write_text(table, encoding="utf-8")
    except (GripperError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(table)
    for path in written + [args.table]:
        print(f"wrote {path}")
    return 0
