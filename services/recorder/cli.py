"""`handover-recorder`: record every key of the bus into one Rerun .rrd per run.

    handover-recorder                         # record to recordings/handover-<time>.rrd
    handover-recorder --output run.rrd        # record to a given file
    handover-recorder --depth-every 1         # also every depth image (4.6 MB/s)
    handover-recorder inspect run.rrd         # rows per entity of a recording
    handover-recorder finalise run.rrd        # add the footer to the file of a killed recorder
    handover-recorder screenshot run.rrd      # a PNG of the run's end in the viewer, no display needed
    rerun run.rrd                             # open it in the viewer

Exit codes: 0 done; 1 a runtime failure (e.g. `finalise` given a file that is not a Rerun
recording: one line, the file left unchanged); 2 a usage error (bad option, missing file);
130 a subcommand stopped by Ctrl-C (the recorder itself stops with 0).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from services.recorder.errors import RecorderError
from services.runtime import base_parser, load_profile, run_main
from services.runtime.paths import unwritable_dir


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
    why = unwritable_dir(output.parent)
    if why is not None:  # before the bus: a recorder that cannot write must not start
        raise RecorderError(f"cannot write a recording into {str(output.parent)!r} ({why}); choose a writable folder")
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


def _finalise(args: argparse.Namespace) -> int:
    from services.recorder.finalise import finalise, missing_file

    paths = [Path(p) for p in args.recordings]
    for path in paths:  # every path checked before any file is touched
        if not path.is_file():
            raise RecorderError(missing_file(path))
    failed = 0
    for path in paths:
        try:
            sys.stdout.write(finalise(path).line() + "\n")
        except RecorderError as exc:
            if len(paths) == 1:
                raise
            sys.stderr.write(f"{args.service_name}: error: {exc}\n")  # as `run_main` words it
            failed += 1
    return 1 if failed else 0


def _screenshot(args: argparse.Namespace) -> int:
    from services.recorder.screenshot import screenshot

    width, height = screenshot(Path(args.recording), Path(args.output_png), args.size)
    sys.stdout.write(f"screenshot: {args.output_png} ({width}x{height} px) of {args.recording}\n")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = base_parser("handover-recorder", "Record every key of the bus (depth images only when asked) to "
                         "a Rerun .rrd (one file per run; valid when killed). Subcommands: `inspect FILE` summarises "
                         "one, `finalise FILE` adds the footer to the file of a killed recorder, `screenshot FILE` "
                         "draws its end in the viewer to a PNG.")
    parser.add_argument("--output", help="recording file (.rrd); default: <output-dir>/handover-<run-id>.rrd")
    parser.add_argument("--output-dir", help="folder for recordings (default: the profile's, else recordings/)")
    parser.add_argument("--run-id", help="name of this run (default: the start time)")
    parser.add_argument("--no-urdf", action="store_true", help="do not log the arm's 3-D model (robot_model = none)")
    parser.add_argument("--depth-every", type=int, metavar="N",
                        help="record depth images, one in N (1: all; 0: not subscribed); overrides the profile")
    sub = parser.add_subparsers(dest="command")
    inspect = sub.add_parser("inspect", help="print the rows logged per entity of a recording")
    inspect.add_argument("recording", help="path to a .rrd file")
    finalise = sub.add_parser(
        "finalise", help="add Rerun's footer to a recording whose recorder was killed (rewritten in place, every "
                         "complete message kept; prints what was kept)",
        description="A recorder stopped normally finalises its file itself. One killed (SIGKILL, a crash) leaves "
                    "it without the footer `rerun rrd verify` needs: this rewrites it with its footer, keeping every "
                    "message that reached the disk (an incomplete last message is dropped, and said so), and prints "
                    "what it kept. A file that already has its footer, or is not a Rerun recording, is left unchanged.")
    finalise.add_argument("recordings", nargs="+", metavar="FILE.rrd", help="recording(s) to finalise")
    shot = sub.add_parser(
        "screenshot", help="a PNG of a recording's end in the real Rerun viewer, without a display",
        description="Runs the viewer of the venv on a private Xvfb display with software Vulkan (loopback only, "
                    "its analytics off in private folders), the recorder's layout with the time cursor at the end "
                    "of the run and the arm the recording holds, and saves its picture. Needs: apt-get install -y "
                    "xvfb mesa-vulkan-drivers. Takes about 6 s for a default run on two cores. The recording is "
                    "not changed.")
    shot.add_argument("recording", metavar="FILE.rrd", help="the recording to draw")
    shot.add_argument("--output", dest="output_png", default="docs/img/rerun_handover.png", metavar="PNG",
                      help="where to write the picture (replaced; default: %(default)s)")
    shot.add_argument("--size", default="1600x1000", metavar="WxH", help="window size in pixels (default: %(default)s)")
    args = parser.parse_args(argv)
    run = {"inspect": _inspect, "finalise": _finalise, "screenshot": _screenshot}.get(args.command, _record)
    return run_main(run, args)


if __name__ == "__main__":
    raise SystemExit(main())
