"""`handover-tracker`: the tracker service, and its pipeline over a replay file.

    handover-tracker [--profile sim] [--replay FILE [--replay-loop]]   run the service
    handover-tracker offline FILE                                      run the pipeline on a file, print a summary
    handover-tracker calibrate-kinect PAIRS.csv -o FILE                the ROS 1 camera's pose from point pairs
    handover-tracker camera-sample DIR                                 the sample camera input of deploy/camera.toml
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from services.runtime import base_parser, load_profile, run_main
from services.tracker.config import TrackerConfig
from services.tracker.config_args import add_config_flags, config_from_args, profile_config
from services.tracker.errors import TrackerConfigError


def run(args: argparse.Namespace) -> int:
    command = args.command or "run"
    if command == "run":
        from services.tracker.node import run_node

        profile = load_profile(args)
        config = config_from_args(args, profile.service_config("tracker"))
        if args.replay is not None and not args.replay.is_file():
            raise TrackerConfigError(f"replay file {args.replay} does not exist")
        return run_node(profile, config, args.replay, args.replay_loop)
    if command == "offline":
        return _offline(args, config_from_args(args, profile_config(args)))
    if command == "calibrate-kinect":
        from services.tracker.ros1.cli_calibrate import calibrate

        return calibrate(args.pairs, args.output, args.frame, args.force)
    if command == "camera-sample":
        from services.tracker.camera.photos import write_sample

        frames = write_sample(args.folder)
        print(f"sample camera input: {frames} frame(s), aligned depth and calibration.toml -> {args.folder}")
        return 0
    raise TrackerConfigError(f"unknown command {command!r}")


def _offline(args: argparse.Namespace, config: TrackerConfig) -> int:
    from bus_schema import topics as T
    from handover_model.robot_geometry import ArmGeometry
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


def build_parser() -> argparse.ArgumentParser:
    parser = base_parser("handover-tracker", "Kinect skeleton tracker with Mincelli hand corrections, "
                                             "body dimensions and object detection")
    parser.add_argument("--replay", type=Path, default=None,
                        help="publish from a replay file instead of the bus inputs")
    parser.add_argument("--replay-loop", action="store_true", help="start the replay file over when it ends")
    add_config_flags(parser)
    sub = parser.add_subparsers(dest="command", metavar="{run,offline,calibrate-kinect,camera-sample}")
    sub.add_parser("run", help="run the service (the default)")
    off = sub.add_parser("offline", help="run the pipeline over a replay file without the bus and print a summary")
    off.add_argument("file", type=Path, help="replay file")
    cal = sub.add_parser("calibrate-kinect", help="the ROS 1 camera's pose in base from points measured in both "
                                                  "frames (docs/kinect_ros1.md#calibration)")
    cal.add_argument("pairs", type=Path, help="CSV: camera_x,camera_y,camera_z,base_x,base_y,base_z (m), one "
                                              "point a line, a header line first")
    cal.add_argument("-o", "--output", type=Path, required=True, help="the calibration file to write")
    cal.add_argument("--frame", default="openni_depth_frame", help="the camera frame the points were read in")
    cal.add_argument("--force", action="store_true", help="overwrite an existing calibration file")
    sample = sub.add_parser("camera-sample", help="write the sample camera input (a photo from scikit-image, its "
                                                  "aligned depth, the calibration) that deploy/camera.toml reads")
    sample.add_argument("folder", type=Path, help="where to write it (deploy/camera_sample for the profile)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    return run_main(run, args, service="tracker")
