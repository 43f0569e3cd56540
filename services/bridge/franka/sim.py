"""franky-sim as a service of the stack: a simulated Franka FR3 that speaks libfranka's network
protocol, on a loopback address.

``python -m services.bridge.franka.sim --profile <profile>`` runs franky-sim's MuJoCo
simulation (1 kHz, physics by MuJoCo, model by pinocchio) and its robot server (libfranka's
TCP port 1337 and UDP loop) and gripper server (TCP 1338) on ``host``, a 127.x.y.z address:
libfranka's ports are fixed, so two simulated robots on one machine need two loopback
addresses (Linux routes all of 127.0.0.0/8 to the loopback interface). The bridge's Franka
backend connects to it exactly as it would to a robot.

It joins the bus as ``franka_sim`` (liveliness and heartbeat only: the robot does not speak
Zenoh), so the launcher can start it, wait for it and stop it. With ``state_file`` it writes
the simulated joints and the Hand's width there (JSON, replaced atomically every
``state_period_s``): what the robot really did, read by tests independently of the bridge.

Configuration: ``[services.franka_sim.config]`` (`FrankaSimConfig`).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import time
from pathlib import Path
from typing import Annotated, Any

import msgspec
from msgspec import Meta

from services.bridge.franka.errors import FrankaConfigError, FrankaError
from services.runtime import Profile, ServiceNode, base_parser, kv, load_profile, run_main

log = logging.getLogger(__name__)

SERVICE_NAME = "franka_sim"


class FrankaSimConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Settings of the simulated Franka.

    Attributes:
        host: the loopback address the robot listens on (127.x.y.z; libfranka's ports are
            fixed: one simulated robot per address).
        initial_q_rad: the arm's start posture (7 values), rad; empty: franky-sim's default
            (0, 0, 0, −1.57, 0, 1.57, 0.785).
        state_file: where to write the simulated joints and Hand width ("" for nowhere).
        state_period_s: how often the state file is rewritten, s.
    """

    host: Annotated[str, Meta(pattern=r"^127\.\d{1,3}\.\d{1,3}\.\d{1,3}$")] = "127.0.0.2"
    initial_q_rad: Annotated[list[Annotated[float, Meta(ge=-5.0, le=5.0)]], Meta(max_length=7)] = []
    state_file: Annotated[str, Meta(max_length=4096)] = ""
    state_period_s: Annotated[float, Meta(ge=0.005, le=5.0)] = 0.02

    def __post_init__(self) -> None:
        if self.initial_q_rad and len(self.initial_q_rad) != 7:
            raise msgspec.ValidationError("initial_q_rad needs 7 values - at `$.initial_q_rad`")


def parse_sim_config(table: dict[str, Any]) -> FrankaSimConfig:
    """Validate ``[services.franka_sim.config]``; raises `FrankaConfigError` naming the key."""
    try:
        return msgspec.convert(table, FrankaSimConfig)
    except msgspec.ValidationError as exc:
        raise FrankaConfigError(f"invalid [services.franka_sim.config]: {exc}") from None


def write_state(path: Path, robot: Any, sim_time_s: float) -> None:
    """Write the robot's joints (rad) and the Hand's width (m) to `path`, atomically."""
    inner = robot.inner_state
    data = {"q_rad": [float(v) for v in inner.q], "dq_rad_s": [float(v) for v in inner.dq],
            "hand_width_m": float(robot.hand_width), "sim_time_s": sim_time_s, "pid": os.getpid()}
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)


def keep_on_loopback(host: str) -> None:
    """Make franky-sim's servers bind `host` (a loopback address) where its code binds every
    interface: its UDP loop socket binds ``0.0.0.0`` (franky-sim 1.0.4, `franka_server.py`),
    and the stack listens on loopback only. Patches the module's `socket` name with a
    namespace whose `socket` class rewrites a wildcard bind; nothing else changes."""
    import socket
    import types

    from franky_sim import franka_server

    class LoopbackSocket(socket.socket):
        def bind(self, address: Any) -> None:
            if isinstance(address, tuple) and address and address[0] in ("0.0.0.0", ""):
                address = (host, *address[1:])
            super().bind(address)

    shim = types.SimpleNamespace(**{name: getattr(socket, name) for name in dir(socket) if not name.startswith("__")})
    shim.socket = LoopbackSocket
    franka_server.socket = shim  # type: ignore[attr-defined]


def run_sim(profile: Profile, config: FrankaSimConfig) -> int:
    """Run the simulated robot until SIGINT/SIGTERM. Returns the exit code."""
    import franky_sim
    from franky_sim.mujoco_simulator import MujocoSimulator

    logging.getLogger("numba").setLevel(logging.WARNING)
    keep_on_loopback(config.host)
    kwargs = {"initial_q": tuple(config.initial_q_rad)} if config.initial_q_rad else {}
    state_path = Path(config.state_file) if config.state_file else None
    with MujocoSimulator(enable_visualization=False) as sim:
        robot = sim.add_robot(**kwargs)
        try:
            server = franky_sim.SimulationServer(sim, hostname_candidates=[config.host])
            server.init()
        except OSError as exc:
            raise FrankaError(f"cannot listen on {config.host} ports 1337/1338 ({exc}): another simulated "
                              "robot uses this address? pick another 127.x.y.z host") from None
        server.run_async(realtime=True)
        try:
            with ServiceNode(SERVICE_NAME, profile) as node:
                node.ready()
                log.info("franka sim running", extra=kv(host=config.host, ports="1337/1338"))
                started = time.monotonic()
                for _ in node.loop(1.0 / config.state_period_s):
                    thread = server.async_thread
                    if thread is None or not thread.is_alive():
                        raise FrankaError("the simulation loop stopped (see the log above)")
                    if state_path is not None:
                        write_state(state_path, robot, time.monotonic() - started)
        finally:
            server.cleanup()
    log.info("franka sim stopped")
    return 0


def _run(args: argparse.Namespace) -> int:
    profile = load_profile(args)
    table = profile.service_config(SERVICE_NAME)
    if args.host:
        table["host"] = args.host
    if args.state_file:
        table["state_file"] = args.state_file
    return run_sim(profile, parse_sim_config(table))


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-franka-sim",
        "A simulated Franka FR3 (franky-sim: MuJoCo physics, libfranka's network protocol) on a "
        "loopback address, for the bridge's Franka backend without a robot (docs/franka.md).")
    parser.set_defaults(service_name=SERVICE_NAME)
    parser.add_argument("--host", default=None,
                        help="loopback address to listen on (127.x.y.z; default: the profile's)")
    parser.add_argument("--state-file", default=None, help="write the simulated joints and Hand width here (JSON)")
    return run_main(_run, parser.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
