"""`handover-bridge`: the robot bridge (simulated Baxter now; hardware backend later)."""

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
    return run_bridge(profile, parse_config(table))


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-bridge",
        "Robot bridge: publishes joint state at the configured rate, follows joint commands, "
        "holds the arm when no fresh command arrives within the time-out (200 ms), and "
        "rejects commands with unknown joints or out-of-limit values.",
    )
    parser.add_argument("--backend", choices=["sim"], default=None,
                        help="robot backend (overrides [services.bridge.config].backend)")
    parser.add_argument("--rate-hz", type=float, default=None,
                        help="joint-state rate in Hz (overrides the profile)")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
