"""The stack's Zenoh router as its own small process (`python -m services.launcher.router`).

`handover-up` starts it first and stops it last. Running it apart keeps the bus's routing off
the launcher's Python interpreter: the launcher's relay of its children's output, its watch
and its job cannot delay a message between two services, and the router needs no GIL.

Protocol with the launcher: the Zenoh config (JSON, from
`services.runtime.profile.zenoh_config_dict(profile, "router")`) arrives on stdin; once the
router listens it writes ``ready <endpoint>`` on stdout; on a config or listen error it writes
one message starting ``router:`` to stderr and exits 1. The launcher reads stdout and stderr
as one pipe for as long as the router runs, so a write of the router never blocks. It runs
until SIGINT or SIGTERM (or until its parent dies: the launcher sets `PR_SET_PDEATHSIG`).
"""

from __future__ import annotations

import json
import os
import signal
import sys

from services.runtime.zenoh_threads import keep_zenoh_default_threads

READY = "ready"


def serve(config_json: str) -> int:
    """Open the router described by `config_json` and block until SIGINT/SIGTERM."""
    keep_zenoh_default_threads()
    import zenoh

    try:
        config = zenoh.Config.from_json5(config_json)
        endpoint = ", ".join(json.loads(config_json).get("listen", {}).get("endpoints", []))
    except Exception as exc:  # noqa: BLE001 - zenoh's ZError or a JSON error: one line, exit 1
        sys.stderr.write(f"router: invalid Zenoh config: {exc}\n")
        return 1
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        session = zenoh.open(config)
    except Exception as exc:  # noqa: BLE001 - zenoh raises ZError for any listen failure: one line, exit 1
        sys.stderr.write(f"router: cannot listen on {endpoint}: {exc}\n")
        return 1
    os.write(1, f"{READY} {endpoint}\n".encode())
    try:
        signal.sigwait({signal.SIGINT, signal.SIGTERM})
    finally:
        session.close()
    return 0


def main() -> int:
    return serve(sys.stdin.read())


if __name__ == "__main__":
    raise SystemExit(main())
