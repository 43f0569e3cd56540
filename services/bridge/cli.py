"""`handover-bridge`: the robot bridge (the simulated arm, or a hardware backend)."""

from __future__ import annotations

import argparse

from services.bridge.config import parse_config
from services.runtime import base_parser, load_profile, run_main


def _run(args: argparse.Namespace) -> int:
    from services.bridge.node import run_bridge

    profile = load_profile(args)
    table = profile.service_config("bridge")
    if args.backend:
        table["backend"] = args.backend
    if args.rate_hz is not None:
        table["rate_hz"] = args.rate_hz
    contact = dict(table.get("contact", {}))
    if args.receiver:
        contact["behaviour"] = args.receiver
        contact.setdefault("enabled", True)
    if args.no_contact:
        contact["enabled"] = False
    if args.pull_angle_deg is not None:
        contact["pull_angle_deg"] = args.pull_angle_deg
    if args.seed is not None:
        contact["seed"] = args.seed
    if contact:
        table["contact"] = contact
    if args.scenario:
        contact["scenario"] = args.scenario
        table["contact"] = contact
    if args.posture:
        contact["posture"] = args.posture
        table["contact"] = contact
    if args.height_m is not None:
        contact["height_m"] = args.height_m
        table["contact"] = contact
    if args.stop_on_tick:
        table["stop_wakes_loop"] = False
    return run_bridge(profile, parse_config(table))


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-bridge",
        "Robot bridge: publishes joint state at the configured rate, follows joint commands, "
        "holds the arm when no fresh command arrives within the time-out (200 ms), "
        "rejects commands with unknown joints or out-of-limit values, and brakes at once on "
        "motion/stop. The simulated Kinect is its own service (python -m services.sim_kinect).",
    )
    parser.add_argument("--backend", choices=["sim", "baxter", "franka"], default=None,
                        help="robot backend (overrides [services.bridge.config].backend); baxter: the real "
                             "robot through the Zenoh ROS 1 bridge (see also handover-bridge-baxter --dry-run)")
    parser.add_argument("--rate-hz", type=float, default=None,
                        help="joint-state rate in Hz (overrides the profile)")
    sim = parser.add_argument_group("contact simulation (sim backend)")
    sim.add_argument("--receiver", choices=["taking", "dropping", "bumping", "hesitating", "absent"],
                     help="simulate the gripper, object and a receiver with this behaviour")
    sim.add_argument("--no-contact", action="store_true", help="simulate the arm only")
    sim.add_argument("--pull-angle-deg", type=float, default=None, help="receiver's pull angle φ (deg, >0 down)")
    sim.add_argument("--seed", type=int, default=None, help="seed of the plant's noise")
    sim.add_argument("--scenario", choices=["handover", "transfer"], default=None,
                     help="handover: object on the table, pick, reach, contact when the receiver's hand "
                          "arrives; transfer: object in the gripper from the start (controller tests)")
    sim.add_argument("--posture", choices=["standing", "sitting"], default=None,
                     help="the scene receiver's posture (give the kinect service the same)")
    sim.add_argument("--height-m", type=float, default=None,
                     help="the scene receiver's height, m (give the kinect service the same)")
    parser.add_argument("--stop-on-tick", action="store_true",
                        help="act on motion/stop only at the next 100 Hz tick (old behaviour, for benchmarks); "
                             "default: a stop wakes the loop at once")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
