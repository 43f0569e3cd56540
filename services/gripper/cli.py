"""`handover-gripper` (`python -m services.gripper`): the fail-safe gripper service.

Other command lines of this package:
    handover-study failsafe    F_ST, F_BT, φ_max (figures: handover-study figures gripper)
    handover-study reproduce   Figures 20–23 and the comparison table
    handover-study bench       Monte-Carlo controller benchmark
"""

from __future__ import annotations

import argparse
import sys

from services.gripper.controllers.registry import controller_summaries
from services.gripper.errors import GripperError
from services.runtime import ServiceError, base_parser, load_profile, run_main


class GripperServiceError(ServiceError):
    """A gripper error reported through the service runtime (one line, exit code 2 when the
    input was bad)."""

    def __init__(self, message: str, bad_input: bool) -> None:
        super().__init__(message)
        self.bad_input = bad_input


def _run(args: argparse.Namespace) -> int:
    from services.gripper.config import parse_config

    profile = load_profile(args)
    table = profile.service_config("gripper")
    for key in ("controller", "rate_hz", "wrench_timeout_s", "motion_timeout_s"):
        value = getattr(args, key)
        if value is not None:
            table[key] = value
    if args.step_in_callback:
        table["step_in_callback"] = True
    from handover_model import robots

    gripper = robots.active().gripper  # the arm's gripper: its travel and its strongest grip (≤ 140 N)
    table.setdefault("max_position_m", gripper.stroke_m)
    table.setdefault("max_grip_force_n", min(gripper.force_max_n, 140.0))
    if args.param:
        params = dict(table.get("controller_params", {}))
        params.update(args.param)
        table["controller_params"] = params
    try:
        config = parse_config(table)
        from services.gripper.core import GripperCore
        from services.gripper.node import run_gripper

        core = GripperCore(config)
    except GripperError as exc:
        raise GripperServiceError(str(exc), bad_input=True) from None
    return run_gripper(profile, config, core)


def _param(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=VALUE")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: the value must be a number") from None


def build_parser() -> argparse.ArgumentParser:
    parser = base_parser(
        "handover-gripper",
        "Fail-safe gripper service: runs a release controller on the live wrist wrench and object "
        "motion, publishes the grip command (force and spring position, eq 3.21), the state "
        "(grasp/slip/release/hold) and one release event. Stale, missing or undecodable sensor "
        "data: holds the grip, never opens.",
    )
    parser.add_argument("--controller", default=None, help="release controller (overrides the profile); see --list")
    parser.add_argument("--rate-hz", type=float, default=None, help="control rate, Hz (thesis 10/25/100; ≤ 1000)")
    parser.add_argument("--wrench-timeout-s", type=float, default=None, help="wrist wrench freshness limit, s")
    parser.add_argument("--motion-timeout-s", type=float, default=None, help="object motion freshness limit, s")
    parser.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                        help="controller parameter override (repeatable), e.g. --param k_i=0.2")
    parser.add_argument("--step-in-callback", action="store_true",
                        help="step in the sensor callback instead of the service's main thread "
                             "(latency comparisons; see docs/gripper.md)")
    parser.add_argument("--list", action="store_true", help="list the controllers and exit")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.list:
        for name, summary in controller_summaries().items():
            sys.stdout.write(f"{name:16s} {summary}\n")
        return 0
    return run_main(_run, args)


if __name__ == "__main__":
    raise SystemExit(main())
