"""A separate process for the access-control tests: connect to the bus as one user and put
raw payloads on keys. ``python -m tests.integration.acl_probe --profile P --endpoint E
--user U [--put KEY PAYLOAD]...``; prints ``connected`` or ``refused: …`` (exit 3)."""

from __future__ import annotations

import argparse
import sys
import time

from services.runtime.errors import BusError
from services.runtime.node import open_session
from services.runtime.profile import load_profile_file


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--profile", required=True)
    parser.add_argument("--endpoint", required=True)
    parser.add_argument("--prefix", default=None)
    parser.add_argument("--user", required=True)
    parser.add_argument("--put", nargs=2, action="append", default=[], metavar=("KEY", "PAYLOAD"))
    parser.add_argument("--repeat", type=int, default=20)
    args = parser.parse_args(argv)
    profile = load_profile_file(args.profile).with_bus(args.endpoint, args.prefix)
    try:
        session = open_session(profile, "client", timeout_s=2.0, user=args.user)
    except BusError as exc:
        print(f"refused: {exc}", flush=True)
        return 3
    print("connected", flush=True)
    try:
        time.sleep(0.3)  # let the router learn the subscribers
        for _ in range(args.repeat):
            for key, payload in args.put:
                session.put(key, payload.encode())
            time.sleep(0.01)
        time.sleep(0.3)
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
