"""Echo process for the bus-hop benchmark.

raw:   a plain Zenoh subscriber whose callback puts the same bytes back (as zenoh's z_pong).
typed: a ServiceNode: the payload is decoded at the edge into a WristWrench, handed to the
       main thread, re-encoded and published back — the path every service uses.
"""

from __future__ import annotations

import argparse

from bus_schema import topics
from services.runtime import ServiceNode, load_profile_file, open_session

PING = "bench/ping"
PONG = "bench/pong"


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--endpoint", required=True)
    parser.add_argument("--mode", choices=["raw", "typed"], required=True)
    args = parser.parse_args()
    profile = load_profile_file("sim").with_bus(args.endpoint, "bench/typed")
    if args.mode == "raw":
        import threading

        session = open_session(profile, "client", user="pong")  # its login when the run has logins
        pub = session.declare_publisher(PONG)
        sub = session.declare_subscriber(PING, lambda s: pub.put(s.payload))
        token = session.liveliness().declare_token("bench/typed/alive/pong")
        stop = threading.Event()
        import signal

        signal.signal(signal.SIGTERM, lambda *_: stop.set())
        stop.wait()
        token.undeclare()
        sub.undeclare()
        session.close()
        return 0
    with ServiceNode("pong", profile) as node:
        sub = node.subscribe(topics.WRIST_WRENCH)
        pub = node.publisher(topics.WRIST_WRENCH.__class__(
            "pong", topics.WRIST_WRENCH.type, "state", 0, "bench", "pong"))
        while not node.should_stop:
            node.wait(0.1)
            for rx in sub.drain():
                pub.put_message(rx.msg)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
