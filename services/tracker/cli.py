"""`handover-tracker`: the tracker service and its offline tools.

    handover-tracker [--profile sim] [--replay FILE [--replay-loop]]   run the service
    handover-tracker record --out FILE [--seed N]                      simulate one episode to a file
    handover-tracker offline FILE                                      run the pipeline on a file, print a summary
    handover-tracker evaluate [--episodes N]                           error table vs sim truth (+ figure)
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from services.runtime import ProfileError, base_parser, load_profile, run_main
from services.tracker.config import TrackerConfig, config_from_dict
from services.tracker.errors import TrackerConfigError


def _add_config_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("tracker")
    g.add_argument("--weight-kg", type=float, default=None, help="receiver's body weight from their profile (kg)")
    g.add_argument("--object-mass-kg", type=float, default=None, help="object mass from the task description (kg)")
    g.add_argument("--no-lag-correction", action="store_true", help="disable Mincelli's lag correction (a)")
    g.add_argument("--no-proximity-filter", action="store_true", help="disable Mincelli's robot-proximity filter (b)")
    g.add_argument("--proximity-mode", choices=["hold", "predict"], default=None, help="what (b) does while engaged")
    g.add_argument("--sensor", choices=["bus", "sim"], default=None,
                   help="skeleton and depth from the bus, or from a simulated Kinect in this process")
    g.add_argument("--publish-depth", action="store_true",
                   help="sensor = \"sim\": also publish perception/depth (for a recorder that records depth)")
    g.add_argument("--posture", choices=["standing", "sitting"], default=None,
                   help="the simulated Kinect's receiver (sensor = \"sim\" only; must match the bridge's)")
    g.add_argument("--kinect-seed", dest="kinect_seed", type=int, default=None,
                   help="the simulated Kinect's noise seed (sensor = \"sim\" only)")


def _config(args: argparse.Namespace, base: dict) -> TrackerConfig:
    values = dict(base)
    if args.weight_kg is not None:
        values["weight_kg"] = args.weight_kg
    if args.object_mass_kg is not None:
        values["object_mass_kg"] = args.object_mass_kg
    if args.no_lag_correction:
        values["lag_correction"] = False
    if args.no_proximity_filter:
        values["proximity_filter"] = False
    if args.proximity_mode is not None:
        values["proximity_mode"] = args.proximity_mode
    if getattr(args, "sensor", None) is not None:
        values["sensor"] = args.sensor
    if getattr(args, "publish_depth", False):
        values["publish_depth"] = True
    sim = values.get("sim_kinect") or {}
    if not isinstance(sim, dict):
        raise TrackerConfigError(f"invalid tracker config: sim_kinect must be a table, got {sim!r:.40}")
    sim = dict(sim)
    if getattr(args, "posture", None) is not None:
        sim["posture"] = args.posture
    if getattr(args, "kinect_seed", None) is not None:
        sim["seed"] = args.kinect_seed
    if sim:
        values["sim_kinect"] = sim
    return config_from_dict(values)


def _profile_config(args: argparse.Namespace) -> dict:
    """[services.tracker.config] of the profile, or {} for the offline commands."""
    try:
        return load_profile(args).service_config("tracker")
    except (ProfileError, OSError, ValueError):  # offline commands work without a usable profile
        return {}


def run(args: argparse.Namespace) -> int:
    command = args.command or "run"
    if command == "run":
        from services.tracker.node import run_node

        profile = load_profile(args)
        config = _config(args, profile.service_config("tracker"))
        if args.replay is not None and not args.replay.is_file():
            raise TrackerConfigError(f"replay file {args.replay} does not exist")
        return run_node(profile, config, args.replay, args.replay_loop)
    if command == "record":
        return _record(args)
    if command == "offline":
        return _offline(args, _config(args, _profile_config(args)))
    if command == "evaluate":
        return _evaluate(args, _config(args, _profile_config(args)))
    raise TrackerConfigError(f"unknown command {command!r}")


def _record(args: argparse.Namespace) -> int:
    from bus_schema import topics as T
    from services.tracker.episodes import run_episode
    from services.tracker.replay import ReplayWriter

    frames = 0
    with ReplayWriter(args.out) as writer:
        for frame in run_episode(args.seed):
            writer.write(frame.t_s, T.JOINT_STATE, frame.joint_state)
            writer.write(frame.t_s, T.DEPTH, frame.depth)
            writer.write(frame.t_s, T.SKELETON, frame.skeleton)
            writer.write(frame.t_s, T.SIM_TRUTH, frame.truth)
            frames += 1
    size_mb = args.out.stat().st_size / 1e6
    print(f"recorded episode seed {args.seed}: {frames} frames, {writer.records} messages, "
          f"{size_mb:.1f} MB -> {args.out}")
    return 0


def _offline(args: argparse.Namespace, config: TrackerConfig) -> int:
    from bus_schema import topics as T
    from robot_sim.kinect.robot_geometry import ArmGeometry
    from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
    from services.tracker.pointcloud import depth_frame_from_message
    from services.tracker.replay import read_replay

    pipe = TrackerPipeline(config, ArmGeometry())
    truth = None
    counts: dict[str, int] = {}
    errors_raw, errors_out = [], []
    frames = tracked = 0
    detection = None
    for item in read_replay(args.file):
        if item.topic is T.JOINT_STATE:
            pipe.on_joint_state(np.asarray(item.msg.position_rad), item.t_s)
        elif item.topic is T.DEPTH:
            pipe.on_depth(depth_frame_from_message(item.msg, item.t_s))
            detection = pipe.detect_object() or detection
        elif item.topic is T.SIM_TRUTH:
            truth = np.asarray(item.msg.receiver_hand_position_m)
        elif item.topic is T.SKELETON:
            est = pipe.on_skeleton(skeleton_frame_from_message(item.msg, item.t_s))
            frames += 1
            if est.tracked:
                tracked += 1
                counts[est.correction] = counts.get(est.correction, 0) + 1
                if truth is not None:
                    errors_raw.append(np.linalg.norm(est.hand_raw_m - truth))
                    errors_out.append(np.linalg.norm(est.hand_m - truth))
    if frames == 0:
        print(f"{args.file}: no skeleton frames")
        return 1
    body = pipe.body.estimate()
    summary = {
        "skeleton_frames": frames,
        "tracked_frames": tracked,
        "corrections": counts,
        "body": {"height_m": round(body.height_m, 3), "arm_span_m": round(body.arm_span_m, 3),
                 "shoulder_height_m": round(body.shoulder_height_m, 3), "posture": body.posture},
    }
    if detection is not None:
        summary["object"] = {"found": detection.found, "position_m": [round(float(v), 3) for v in detection.position_m],
                             "size_m": [round(float(v), 3) for v in detection.size_m]}
    if errors_out:
        summary["hand_error_mm"] = {
            "raw_median": round(float(np.median(errors_raw)) * 1000, 1),
            "corrected_median": round(float(np.median(errors_out)) * 1000, 1),
            "raw_p90": round(float(np.percentile(errors_raw, 90)) * 1000, 1),
            "corrected_p90": round(float(np.percentile(errors_out, 90)) * 1000, 1),
        }
    print(json.dumps(summary, indent=2))
    return 0


def _evaluate(args: argparse.Namespace, config: TrackerConfig) -> int:
    from services.tracker.evaluate import markdown_table, plot_trace, run_evaluation, write_results

    summary, trace = run_evaluation(args.episodes, args.seed, config, progress=sys.stderr.isatty())
    print(markdown_table(summary))
    write_results(summary, args.json, args.episodes, args.seed)
    print(f"\nresults: {args.json}")
    if args.figure is not None and trace is not None:
        plot_trace(trace, args.figure)
        print(f"figure: {args.figure}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = base_parser("handover-tracker", "Kinect skeleton tracker with Mincelli hand corrections, "
                                             "body dimensions and object detection")
    parser.add_argument("--replay", type=Path, default=None,
                        help="publish from a replay file instead of the bus inputs")
    parser.add_argument("--replay-loop", action="store_true", help="start the replay file over when it ends")
    _add_config_flags(parser)
    sub = parser.add_subparsers(dest="command", metavar="{run,record,offline,evaluate}")
    sub.add_parser("run", help="run the service (the default)")
    rec = sub.add_parser("record", help="simulate one seeded episode and write a replay file")
    rec.add_argument("--out", type=Path, required=True, help="replay file to write")
    rec.add_argument("--seed", type=int, default=0, help="episode seed")
    off = sub.add_parser("offline", help="run the pipeline over a replay file without the bus and print a summary")
    off.add_argument("file", type=Path, help="replay file")
    ev = sub.add_parser("evaluate", help="hand error vs simulator truth, per correction and phase")
    ev.add_argument("--episodes", type=int, default=20, help="number of seeded episodes")
    ev.add_argument("--seed", type=int, default=0, help="first seed")
    ev.add_argument("--json", type=Path, default=Path("out/tracker/evaluation.json"), help="results file")
    ev.add_argument("--figure", type=Path, default=None,
                    help="write the raw-vs-corrected figure of the first episode here")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "evaluate" and args.episodes < 1:
        parser.error("--episodes must be >= 1")
    return run_main(run, args, service="tracker")
