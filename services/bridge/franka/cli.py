"""``python -m services.bridge.franka``: the bridge with the Franka hardware backend.

Same bus contract as ``handover-bridge`` (joint state out at 100 Hz, joint and gripper
commands in, 200 ms hold, brake on `motion/stop`), but the robot is a Franka Panda / FR3
reached through libfranka (franky). ``--dry-run`` connects, reads and publishes the robot's
state, and prints every motion it would send without moving anything.
"""

from __future__ import annotations

import argparse

from services.runtime import base_parser, load_profile, run_main


def _run(args: argparse.Namespace) -> int:
    from services.bridge.backend import make_backend, print_dry_run_line
    from services.bridge.config import parse_config
    from services.bridge.node import run_bridge

    profile = load_profile(args)
    table = profile.service_config("bridge")
    table["backend"] = "franka"
    if args.rate_hz is not None:
        table["rate_hz"] = args.rate_hz
    franka = dict(table.get("franka", {}))
    if args.host:
        franka["host"] = args.host
    if args.recover:
        franka["recover_on_start"] = True
    table["franka"] = franka
    config = parse_config(table)

    backend = make_backend("franka", franka=config.franka, dry_run=args.dry_run,
                           dry_run_sink=print_dry_run_line if args.dry_run else None)
    return run_bridge(profile, config, backend=backend)


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-bridge-franka",
        "Robot bridge for a Franka Panda / FR3 (libfranka through franky): publishes joint state "
        "at the bridge rate, follows joint commands as velocity motions within the robot's limits, "
        "brings the arm to rest when no fresh command arrives within 200 ms, brakes at once on "
        "motion/stop, drives the Franka Hand, and stops with the robot's error named when the robot "
        "faults or the link is lost. See docs/franka.md.",
    )
    parser.set_defaults(service_name="bridge")
    parser.add_argument("--dry-run", action="store_true",
                        help="move nothing: read and publish the robot's state, print each motion that would be sent")
    parser.add_argument("--host", default=None,
                        help="the robot's FCI address (overrides [services.bridge.config.franka].host)")
    parser.add_argument("--recover", action="store_true",
                        help="run the robot's automatic error recovery at start (else refuse a robot in error)")
    parser.add_argument("--rate-hz", type=float, default=None, help="bridge rate in Hz (overrides the profile)")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
