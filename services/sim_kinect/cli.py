"""`handover-sim-kinect` (``python -m services.sim_kinect``): the simulated Kinect service."""

from __future__ import annotations

import argparse

from services.runtime import base_parser, load_profile, run_main
from services.sim_kinect.config import parse_config
from services.sim_kinect.node import SERVICE_NAME


def _run(args: argparse.Namespace) -> int:
    profile = load_profile(args)
    table = profile.service_config(SERVICE_NAME)
    overrides = {"posture": args.posture, "height_m": args.height_m, "seed": args.seed,
                 "rate_hz": args.rate_hz, "scene": args.scene}
    table.update({k: v for k, v in overrides.items() if v is not None})
    if args.hand_target_m is not None:
        table["hand_target_base_m"] = list(args.hand_target_m)
    config = parse_config(table)  # before importing the renderer: bad input fails fast
    from services.sim_kinect.node import run_kinect

    return run_kinect(profile, config)


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-sim-kinect",
        "Simulated Kinect: renders the receiver, the table, the object and the robot's arm at 30 Hz "
        "(robot_sim.kinect) and publishes perception/skeleton, perception/depth and its ground "
        "truth sim/kinect_truth. Reads robot/joint_state (the arm) and, with --scene handover, "
        "sim/truth (the receiver's hand and the object from the bridge's handover scene). "
        "Settings: [services.kinect.config] of the profile; the flags below override it.",
    )
    parser.set_defaults(service_name=SERVICE_NAME)
    body = parser.add_argument_group("the receiver (must match the bridge's scene receiver)")
    body.add_argument("--posture", choices=["standing", "sitting"], default=None, help="the receiver's posture")
    body.add_argument("--height-m", type=float, default=None, help="the receiver's height, m (1.2–2.2)")
    body.add_argument("--seed", type=int, default=None, help="seed of the skeleton errors and depth noise")
    cam = parser.add_argument_group("camera and scene")
    cam.add_argument("--rate-hz", type=float, default=None, help="frame rate, Hz (Kinect: 30)")
    cam.add_argument("--scene", choices=["handover", "none"], default=None,
                     help="handover: the receiver's hand and the object follow sim/truth; none: the Kinect's "
                          "own scripted reach and the object on the table")
    cam.add_argument("--hand-target-m", type=float, nargs=3, metavar=("X", "Y", "Z"), default=None,
                     help="scripted reach target of the right hand (base frame, m; scene none)")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
