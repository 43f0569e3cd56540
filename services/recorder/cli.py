"""`handover-recorder`: record everything on the bus into one Rerun .rrd per run.

    handover-recorder                         # record to recordings/handover-<time>.rrd
    handover-recorder --output run.rrd        # record to a given file
    handover-recorder inspect run.rrd         # rows per entity of a recording
    rerun run.rrd                             # open it in the viewer
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from services.recorder.errors import RecorderError
from services.runtime import base_parser, load_profile, run_main


def _record(args: argparse.Namespace) -> int:
    from services.recorder.node import default_output_path, run_recorder

    profile = load_profile(args)
    cfg = profile.service_config("recorder")
    unknown = set(cfg) - {"urdf", "output_dir", "flush_period_s", "depth_every"}
    if unknown:
        raise RecorderError(f"unknown keys in [services.recorder.config]: {sorted(unknown)}")
    if args.output:
        output = Path(args.output)
        if output.suffix != ".rrd":
            raise RecorderError(f"--output {output} must end in .rrd")
    else:
        directory = Path(args.output_dir or cfg.get("output_dir", "recordings"))
        output = default_output_path(directory, args.run_id or time.strftime("%Y%m%d-%H%M%S"))
    flush = float(cfg.get("flush_period_s", 0.1))
    if not 0.01 <= flush <= 10:
        raise RecorderError("[services.recorder.config].flush_period_s must be within 0.01–10 s")
    depth_every = cfg.get("depth_every", 3)
    if not isinstance(depth_every, int) or not 1 <= depth_every <= 100:
        raise RecorderError("[services.recorder.config].depth_every must be an integer within 1–100")
    return run_recorder(profile, output, log_urdf=bool(cfg.get("urdf", True)) and not args.no_urdf,
                        flush_period_s=flush, depth_every=depth_every)


def _inspect(args: argparse.Namespace) -> int:
    from services.recorder.readback import entity_row_counts

    counts = entity_row_counts(Path(args.recording))
    width = max((len(k) for k in counts), default=10)
    sys.stdout.write(f"{'entity':<{width}}  rows\n")
    for entity, rows in counts.items():
        sys.stdout.write(f"{entity:<{width}}  {rows}\n")
    sys.stdout.write(f"{len(counts)} entities, {sum(counts.values())} rows\n")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = base_parser("handover-recorder", "Record every message under <prefix>/** to a Rerun .rrd "
                         "(one file per run; valid when killed). Subcommand `inspect FILE` summarises one.")
    parser.add_argument("--output", help="recording file (.rrd); default: <output-dir>/handover-<run-id>.rrd")
    parser.add_argument("--output-dir", help="folder for recordings (default: the profile's, else recordings/)")
    parser.add_argument("--run-id", help="name of this run (default: the start time)")
    parser.add_argument("--no-urdf", action="store_true", help="do not log Baxter's 3-D model")
    sub = parser.add_subparsers(dest="command")
    inspect = sub.add_parser("inspect", help="print the rows logged per entity of a recording")
    inspect.add_argument("recording", help="path to a .rrd file")
    args = parser.parse_args(argv)
    return run_main(_inspect if args.command == "inspect" else _record, args)


if __name__ == "__main__":
    raise SystemExit(main())
