"""A scripted handover for the sim bridge backend, tick by tick, without a bus.

`default_backend` builds the backend the bridge builds for the default profile
(`deploy/sim.toml`, `[services.bridge.config]`); `script` yields one scripted tick at a time
for it: the arm moves empty to the object on the table, picks it (grip command 10 N), holds
it still, carries it to the transfer point in front of the receiver and holds there; the
receiver reaches, the contact starts, the gripper opens a little later; then the arm rests
(the receiver holds the object, or it fell). Joint targets come from a damped least-squares
IK of the tool position (`base` frame, m) on Baxter's right arm.

Each `Tick` says what the bridge loop does on that tick (command with feed-forward, hold,
grip command, the elapsed time `dt_s`, a catch-up gap) and a `state` label used by the
benchmark: ``moving_empty`` (d), ``held_still`` (b), ``transfer`` (c), ``rest`` (a), and
``other`` for ticks in between. Used by `test_handover_equivalence.py` and the bridge
tick benchmark recorded in docs/bridge.md.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handover_model import scene as layout
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, arm_model
from services.bridge.backend import make_backend
from services.bridge.config import BridgeConfig, parse_config
from services.bridge.handover_backend import HandoverSimBackend

PROFILE = Path(__file__).resolve().parents[3] / "deploy" / "sim.toml"
DT_S = 0.01
#: Transfer point in front of the receiver (`base`, m): in the task plane, within reach.
TRANSFER_M = np.array([0.45, -0.259, 0.285])
GRIP_N = 10.0


@dataclass(frozen=True)
class Tick:
    """One scripted bridge tick: the command (rad, rad/s; None: hold), the grip command (N),
    the elapsed time (s), a catch-up gap before it (s, 0: none) and the benchmark label."""

    target_rad: np.ndarray | None
    feedforward_rad_s: np.ndarray | None
    grip_n: float
    dt_s: float = DT_S
    gap_s: float = 0.0
    state: str = "other"


def profile_config(behaviour: str | None = None) -> BridgeConfig:
    """`[services.bridge.config]` of the default profile (optionally another receiver)."""
    table = tomllib.loads(PROFILE.read_text())["services"]["bridge"]["config"]
    if behaviour is not None:
        table["contact"]["behaviour"] = behaviour
    return parse_config(table)


def default_backend(behaviour: str | None = None) -> HandoverSimBackend:
    """The sim backend as `services.bridge.node.run_bridge` builds it for the default profile."""
    config = profile_config(behaviour)
    backend = make_backend(config.backend, contact=config.contact, time_constant_s=config.servo_time_constant_s,
                           initial_position_rad=None, robot_command_timeout_s=config.sim_robot_command_timeout_s)
    assert isinstance(backend, HandoverSimBackend)
    return backend


def ik(target_m: np.ndarray, q0_rad: np.ndarray, iterations: int = 200) -> np.ndarray:
    """Joint positions (rad) that put the tool at `target_m` (`base`, m), from `q0_rad`
    (position-only damped least squares, within the joint limits)."""
    import pinocchio as pin

    model = arm_model()
    q = np.array(q0_rad, dtype=float)
    for _ in range(iterations):
        error = np.asarray(target_m) - model.tool_pose(q)[0]
        if np.linalg.norm(error) < 1e-6:
            break
        jac = pin.computeFrameJacobian(model.model, model.data, q, model.tool_frame_id,
                                       pin.LOCAL_WORLD_ALIGNED)[:3]
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(3), error)
        q = np.clip(q + step, model.limits.lower_rad, model.limits.upper_rad)
    return q


def _move(q_from: np.ndarray, q_to: np.ndarray, duration_s: float, grip_n: float, state: str) -> Iterator[Tick]:
    """A minimum-jerk joint move (targets with their rates as feed-forward)."""
    n = max(1, round(duration_s / DT_S))
    for i in range(1, n + 1):
        tau = i / n
        s = tau**3 * (10 - 15 * tau + 6 * tau**2)
        ds = 30 * tau**2 * (1 - tau) ** 2 / duration_s
        yield Tick(q_from + s * (q_to - q_from), ds * (q_to - q_from), grip_n, state=state)


def _hold(duration_s: float, grip_n: float, state: str) -> Iterator[Tick]:
    for _ in range(round(duration_s / DT_S)):
        yield Tick(None, None, grip_n, state=state)


@dataclass(frozen=True)
class Poses:
    """Joint postures of the script (rad): home, above the object, at the object, lifted,
    at the transfer point."""

    home: np.ndarray
    above: np.ndarray
    pick: np.ndarray
    lifted: np.ndarray
    transfer: np.ndarray


def poses() -> Poses:
    home = np.array(RIGHT_ARM_HOME_RAD)
    obj = np.array(layout.OBJECT_PICK_BASE_M, dtype=float)
    above = ik(obj + np.array([0.0, 0.0, 0.10]), home)
    pick = ik(obj, above)
    lifted = ik(obj + np.array([0.0, 0.0, 0.15]), pick)
    return Poses(home, above, pick, lifted, ik(TRANSFER_M, lifted))


def script(backend: HandoverSimBackend, p: Poses, rest_s: float = 3.0, irregular: bool = True) -> Iterator[Tick]:
    """One handover episode for `backend` (a generator: it reads the scene between ticks).

    Empty move to the object, pick, held still, carry, wait for the contact at the transfer
    point, open the gripper 0.6 s into the contact, then rest for `rest_s`. With `irregular`,
    some ticks are short extra ticks (a stop woke the loop) or follow a catch-up gap."""
    scene = backend.scene
    yield from _move(p.home, p.above, 1.5, 0.0, "moving_empty")
    yield from _move(p.above, p.pick, 0.5, 0.0, "moving_empty")
    yield from _hold(0.2, 0.0, "other")
    yield from _hold(0.1, GRIP_N, "other")  # the pick
    assert scene.object_phase == "in_gripper", scene.object_phase
    yield from _hold(1.0, GRIP_N, "held_still")
    if irregular:
        yield Tick(None, None, GRIP_N, dt_s=0.0003, state="other")
        yield Tick(None, None, GRIP_N, dt_s=0.0097, gap_s=0.03, state="other")
        yield Tick(None, None, 12.0, dt_s=0.0125, state="other")
        yield from _hold(0.05, GRIP_N, "other")
    yield from _move(p.pick, p.lifted, 1.0, GRIP_N, "other")
    yield from _move(p.lifted, p.transfer, 1.8, GRIP_N, "other")
    for _ in range(500):  # until the receiver's hand arrives
        if scene.receiver_phase == "contact":
            break
        yield Tick(None, None, GRIP_N, state="other")
    assert scene.receiver_phase == "contact", scene.receiver_phase
    yield from _hold(0.6, GRIP_N, "transfer")
    for i in range(300):  # the gripper opens; the receiver takes the object, or it falls
        if scene.object_phase != "in_gripper":
            break
        yield Tick(None, None, 0.0, dt_s=0.0004 if irregular and i % 7 == 3 else DT_S, state="transfer")
    yield from _hold(1.0, 0.0, "other")  # the receiver settles (or the object falls)
    yield from _hold(rest_s, 0.0, "rest")


def empty_moves(p: Poses, cycles: int = 1) -> Iterator[Tick]:
    """The arm moving back and forth with no object (state d)."""
    for _ in range(cycles):
        yield from _move(p.home, p.above, 1.0, 0.0, "moving_empty")
        yield from _move(p.above, p.home, 1.0, 0.0, "moving_empty")


def apply(backend: HandoverSimBackend, tick: Tick) -> None:
    """Run one tick on `backend` the way the bridge loop does (catch-up, read, grip, command
    or hold, step)."""
    if tick.gap_s > 0.0:
        backend.catch_up(tick.gap_s)
    backend.read()  # the loop reads the arm before it acts (no side effect: copies)
    backend.gripper_command(tick.grip_n)
    if tick.target_rad is None:
        backend.hold()
    else:
        backend.command(tick.target_rad, tick.feedforward_rad_s)
    backend.step(tick.dt_s)
