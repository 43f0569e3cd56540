"""What per-run bus logins cost (issue 17): one bus hop through a real router process with and
without logins and the deny-by-default list, and the default stack's start-up time with
`logins = "per-run"` against `"off"`. The two variants take turns (A B A B) in one run; medians,
p99 and the ratios go to docs/security.md between its bench markers.

Run: python -m pytest tests/bench/test_bench_logins.py -m bench -s
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from services.launcher.logins import create_run_logins
from services.launcher.processes import RouterProcess
from services.runtime.node import open_session
from services.runtime.bus_access import AccessControl, BusAuth, UserPermissions
from services.runtime.profile import free_tcp_port, load_profile_file
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime.testing import loopback_profile
from tests.bench._report import save, summarize, table
from tests.bench.pong import PING, PONG
from tests.bench.test_bench_bus import _raw_round_trips

pytestmark = pytest.mark.bench
REPO = Path(__file__).resolve().parents[2]
DOC = REPO / "docs" / "security.md"
BEGIN, END = "<!-- logins-bench:begin -->", "<!-- logins-bench:end -->"
ROUNDS = 2
N_PINGS = 2000
PREFIX = "bench/typed"  # tests.bench.pong's prefix
_ALIVE = re.compile(r"all \d+ services alive [\d.]+ s after start \(([\d.]+) s after launch\)")


def _hops(tmp: Path, logins: bool) -> list[float]:
    """One-way hop times (round trip / 2, s) between this process and a pong process."""
    profile = loopback_profile(free_tcp_port()).with_bus(prefix=PREFIX)
    acl_prefix = PREFIX.split("/")[0]  # the ping and pong keys (bench/ping, bench/pong) lie under it
    env = {k: v for k, v in os.environ.items() if k != "HANDOVER_BUS_CREDENTIALS"}
    ping_profile = router_profile = dataclasses.replace(profile, logins="off")
    if logins:
        run = create_run_logins(tmp / f"bus-{time.monotonic_ns()}", ["ping", "pong"])
        acl = AccessControl("deny", {"ping": UserPermissions(publish=("bench/ping",), subscribe=("bench/pong",)),
                                     "pong": UserPermissions(publish=("bench/pong",), subscribe=("bench/ping",))})
        router_profile = dataclasses.replace(profile, prefix=acl_prefix, auth=BusAuth(run.dictionary),
                                             access_control=acl)
        ping_profile = dataclasses.replace(profile, auth=BusAuth(run.user_file("ping")))
        env["HANDOVER_BUS_CREDENTIALS"] = str(run.user_file("pong"))
    router = RouterProcess(json.dumps(zenoh_config_dict(router_profile, "router")))
    router.start()
    proc = subprocess.Popen([sys.executable, "-m", "tests.bench.pong", "--endpoint", profile.endpoint,
                             "--mode", "raw"], env=env, cwd=REPO)
    try:
        _wait_for_pong(ping_profile)
        return [r / 2 for r in _raw_round_trips(ping_profile, N_PINGS, user="ping")]
    finally:
        proc.terminate()
        proc.wait(10)
        router.stop()


def _wait_for_pong(profile) -> None:
    """Ping until the pong process answers (its session is up and its subscription known)."""
    session = open_session(profile, "client", timeout_s=20.0, user="ping")
    answered: list[bool] = []
    sub = session.declare_subscriber(PONG, lambda _s: answered.append(True))
    try:
        deadline = time.monotonic() + 20.0
        while not answered:
            assert time.monotonic() < deadline, "pong never answered"
            session.put(PING, b"hello")
            time.sleep(0.05)
    finally:
        sub.undeclare()
        session.close()


def _startup_s(tmp: Path, logins: bool) -> float:
    """Seconds from `handover-up --job check`'s launch to every service alive."""
    path = tmp / f"profile-{logins}.toml"
    text = load_profile_file("sim").path.read_text()
    path.write_text(text if logins else text.replace('logins = "per-run"', 'logins = "off"', 1))
    env = {k: v for k, v in os.environ.items() if k != "HANDOVER_BUS_CREDENTIALS"}
    out = subprocess.run([sys.executable, "-m", "services.launcher", "--profile", str(path), "--port", "auto",
                          "--job", "check", "--recording-dir", str(tmp / "rec"), "--run-id", f"s{time.time_ns()}"],
                         capture_output=True, text=True, timeout=120, env=env, cwd=REPO)
    match = _ALIVE.search(out.stdout)
    assert out.returncode == 0 and match, out.stdout[-2000:] + out.stderr[-2000:]
    return float(match.group(1))


def test_what_per_run_logins_cost(tmp_path: Path) -> None:
    hops: dict[bool, list[float]] = {False: [], True: []}
    starts: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(ROUNDS):
        for logins in (False, True):  # A B A B
            hops[logins] += _hops(tmp_path, logins)
            starts[logins].append(_startup_s(tmp_path, logins))
    hop = {k: summarize(v) for k, v in hops.items()}
    start = {k: float(np.median(v)) for k, v in starts.items()}
    rows = [(name, f"{hop[k]['median'] * 1e6:.0f}", f"{hop[k]['p99'] * 1e6:.0f}", f"{start[k]:.2f}")
            for name, k in (("no logins", False), ("per-run logins + ACL", True))]
    rows.append(("ratio logins / none", f"{hop[True]['median'] / hop[False]['median']:.2f}x",
                 f"{hop[True]['p99'] / hop[False]['p99']:.2f}x", f"{start[True] / start[False]:.2f}x"))
    header = ("bus", "hop median (µs)", "hop p99 (µs)", "start-up to all alive (s, median)")
    print("\n" + table(rows, header))
    save("logins", {"hop_s": {str(k): v for k, v in hop.items()}, "startup_s": {str(k): v for k, v in starts.items()}})
    lines = [table(rows, header), "",
             f"One hop = round trip / 2 between two processes through a real router process (raw Zenoh put, "
             f"{N_PINGS} pings a round after a warm-up); start-up = `handover-up --job check` from launch to every "
             f"service alive. {ROUNDS} rounds, the two variants in turns, on {os.cpu_count()} cores, "
             f"{time.strftime('%Y-%m-%d')}. Generated by `tests/bench/test_bench_logins.py`."]
    text = DOC.read_text()
    head, rest = text.split(BEGIN, 1)
    DOC.write_text(head + BEGIN + "\n" + "\n".join(lines) + "\n" + END + rest.split(END, 1)[1])
    assert hop[True]["median"] < 0.002  # a sanity bound; the figures are reported, not asserted
