"""`handover-supervisor`: the handover sequencer as a service."""

from __future__ import annotations

import argparse

from services.runtime import base_parser, load_profile, run_main
from services.supervisor.config import parse_config


def _run(args: argparse.Namespace) -> int:
    from services.supervisor.node import run_supervisor

    profile = load_profile(args)
    table = dict(profile.service_config("supervisor"))
    for key in ("episodes", "transfer_timeout_s"):
        value = getattr(args, key)
        if value is not None:
            table[key] = value
    return run_supervisor(profile, parse_config(table))


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-supervisor",
        "Handover supervisor: sequences locate → pick → plan → reach → transfer → released → "
        "retract → done at 100 Hz, stops the arm at once on the gripper's release event, and "
        "makes a protective stop when a service is lost or silent. Publishes supervisor/state "
        "and one supervisor/episode summary per episode.",
    )
    parser.add_argument("--episodes", type=int, default=None,
                        help="episodes to run (0: until stopped; default from the profile, else 1)")
    parser.add_argument("--transfer-timeout-s", dest="transfer_timeout_s", type=float, default=None,
                        help="retract with the object if the receiver has not taken it after this long")
    return run_main(_run, parser.parse_args(argv))
