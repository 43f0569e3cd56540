"""``python -m services.bridge.baxter``: the bridge with the Baxter hardware backend.

Same bus contract as ``handover-bridge`` (joint state out, joint and gripper commands in,
200 ms hold), but the robot is a real Baxter reached through the Zenoh ROS 1 bridge.
``--dry-run`` connects, reads the robot and prints every ROS 1 message it would send
(topic key, type, MD5, bytes) without sending anything.
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
    table["backend"] = "baxter"
    if args.rate_hz is not None:
        table["rate_hz"] = args.rate_hz
    if args.enable:
        table["baxter"] = {**table.get("baxter", {}), "enable_on_start": True}
    config = parse_config(table)

    backend = make_backend("baxter", profile=profile, baxter=config.baxter, dry_run=args.dry_run,
                           dry_run_sink=print_dry_run_line if args.dry_run else None)
    return run_bridge(profile, config, backend=backend)


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-bridge-baxter",
        "Robot bridge for a real Baxter (ROS 1 topics over the Zenoh ROS 1 bridge): publishes "
        "joint state, follows joint commands in position mode at the bridge rate, holds when "
        "no fresh command arrives within 200 ms, clamps commands to the joint limits, and "
        "refuses to start unless the robot is enabled.",
    )
    parser.set_defaults(service_name="bridge")
    parser.add_argument("--dry-run", action="store_true",
                        help="send nothing to the robot: print each ROS 1 message that would be sent")
    parser.add_argument("--enable", action="store_true",
                        help="enable the robot at start (else refuse to start on a disabled robot)")
    parser.add_argument("--rate-hz", type=float, default=None, help="bridge rate in Hz (overrides the profile)")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
