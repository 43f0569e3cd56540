"""`handover-recorder`: record every key of the bus into one Rerun .rrd per run.

    handover-recorder                         # record to recordings/handover-<time>.rrd
    handover-recorder --output run.rrd        # record to a given file
    handover-recorder --depth-every 1         # also every depth image (4.6 MB/s)
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
    import msgspec

    from services.recorder.config import parse_config
    from services.recorder.node import default_output_path, run_recorder

    profile = load_profile(args)
    config = parse_config(profile.service_config("recorder"))
    if args.no_urdf:
        config = msgspec.structs.replace(config, robot_model="none")
    if args.depth_every is not None:
        if not 0 <= args.depth_every <= 100:
            raise RecorderError("--depth-every must be within 0–100")
        config = msgspec.structs.replace(config, depth_every=args.depth_every)
    if args.output:
        output = Path(args.output)
        if output.suffix != ".rrd":
            raise RecorderError(f"--output {output} must end in .rrd")
    else:
        directory = Path(args.output_dir or config.output_dir)
        output = default_output_path(directory, args.run_id or time.strftime("%Y%m%d-%H%M%S"))
    return run_recorder(profile, output, config)


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
    parser = base_parser("handover-recorder", "Record every key of the bus (depth images only when asked) to "
                         "a Rerun .rrd (one file per run; valid when killed). Subcommand `inspect FILE` summarises "
                         "one.")
    parser.add_argument("--output", help="recording file (.rrd); default: <output-dir>/handover-<run-id>.rrd")
    parser.add_argument("--output-dir", help="folder for recordings (default: the profile's, else recordings/)")
    parser.add_argument("--run-id", help="name of this run (default: the start time)")
    parser.add_argument("--no-urdf", action="store_true", help="do not log Baxter's 3-D model (robot_model = none)")
    parser.add_argument("--depth-every", type=int, metavar="N",
                        help="record depth images, one in N (1: all; 0: not subscribed); overrides the profile")
    sub = parser.add_subparsers(dest="command")
    inspect = sub.add_parser("inspect", help="print the rows logged per entity of a recording")
    inspect.add_argument("recording", help="path to a .rrd file")
    args = parser.parse_args(argv)
    return run_main(_inspect if args.command == "inspect" else _record, args)


if __name__ == "__main__":
    raise SystemExit(main())
