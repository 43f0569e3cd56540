"""Run one cross-check scenario on our plant (`robot_sim.contact.plant.ContactPlant`, stepped
directly) or on MuJoCo (`MujocoPinch`), recording the same time series from both.

What both plants share (the scenario's inputs, not the physics under test):
- the grip force F_G(t): the grip-command schedule through our gripper actuator model
  (`GripperActuator`: 25 Hz latch, lag, 50 N/s), which our plant steps internally and which
  here drives MuJoCo's pad motors, so both see the same F_G(t);
- the hand: a prescribed force, or a receiver behaviour's law (impedance around r(t), grasp
  coupling, weight feedforward, force cap), evaluated each step from each plant's own state.

Our plant takes a prescribed force through its receiver: a full grasp of unlimited strength,
whose hand is placed each step at p + F/k_c with the object's velocity, so that the grasp
spring (stiffness k_c) transmits exactly F during that step. The contact physics (stick,
slip, leaving the pads, falling) is each plant's own.

Frames and units: our gripper frame (x toward the receiver, y DOWN); m, m/s, N, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from robot_sim.contact.actuator import GripperActuator
from robot_sim.contact.backend import ScalarBackend
from robot_sim.contact.config import HandParams, SimConfig
from robot_sim.contact.crosscheck.mjcf import MujocoParams, MujocoPinch
from robot_sim.contact.crosscheck.scenario import Scenario, grip_command_at
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import Coupling, ReceiverParams, absent, reference, with_overrides

__all__ = ["Run", "run_ours", "run_mujoco", "receiver_forces"]


@dataclass(frozen=True)
class Run:
    """One plant's time series of a scenario (sampled after each step).

    plant: "ours" or "mujoco". extent_x_m, extent_y_m: how far the object slides along x or
    y before it leaves that plant's pads (m). contacts: pad contact points (MuJoCo's
    collision count; ours: 1 while pads press, else 0). holds: the receiver's hand holds the
    object (grasp ≥ hold level, within 2 cm). Other arrays as named (our frame)."""

    plant: str
    extent_x_m: float
    extent_y_m: float
    time_s: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    vx_m_s: np.ndarray
    vy_m_s: np.ndarray
    grip_force_n: np.ndarray
    hand_force_x_n: np.ndarray
    hand_force_y_n: np.ndarray
    hand_x_m: np.ndarray
    hand_y_m: np.ndarray
    holds: np.ndarray
    contacts: np.ndarray

    @property
    def speed_m_s(self) -> np.ndarray:
        """Slip speed relative to the (fixed) pads (m/s)."""
        return np.hypot(self.vx_m_s, self.vy_m_s)

    @property
    def left(self) -> np.ndarray:
        """True from the first sample beyond the pads' footprint on (it has left for good)."""
        out = (np.abs(self.x_m) > self.extent_x_m) | (np.abs(self.y_m) > self.extent_y_m)
        return np.logical_or.accumulate(out)


_SERIES = [f.name for f in fields(Run)][3:]


class _Recorder:
    def __init__(self) -> None:
        self.rows: list[tuple] = []

    def run(self, plant: str, extent_x_m: float, extent_y_m: float) -> Run:
        cols = list(zip(*self.rows))
        arrays = {name: np.asarray(col, dtype=bool if name == "holds" else float) for name, col in zip(_SERIES, cols)}
        return Run(plant=plant, extent_x_m=extent_x_m, extent_y_m=extent_y_m, **arrays)


def _force_probe() -> ReceiverParams:
    """A receiver whose full grasp (unlimited strength, no feedforward) is on from t = 0:
    the hand placed at p + F/k_c transmits exactly F (module docstring)."""
    return with_overrides(absent(), coupling=Coupling.FULL, grasp_start_s=-1.0, grasp_build_s=1e-3,
                          grasp_level=1.0, grasp_strength_n=1e9, weight_feedforward=0.0)


def run_ours(sc: Scenario, sim: SimConfig = SimConfig()) -> Run:
    """The scenario on our contact plant (one episode, float backend)."""
    config = replace(sim, obj=sc.object_params(sim.obj), duration_s=sc.duration_s)
    p = ContactPlant(config, sc.receiver or _force_probe(), seed=0, initial_grip_force_n=sc.grip[0][1])
    kc, dt = config.hand.grasp_stiffness_n_per_m, config.dt_s
    rec = _Recorder()
    probe = sc.receiver is None
    for k in range(config.n_steps):
        t = k * dt
        if probe:
            fx, fy = sc.hand_force_n(t)
            p.hx, p.hy, p.hvx, p.hvy = p.px + fx / kc, p.py + fy / kc, p.vx, p.vy
        p.step(float(grip_command_at(sc.grip, t)))
        hand = (math.nan, math.nan, False) if probe else (p.hx, p.hy, p.holds)  # a probe is no receiver
        rec.rows.append((p.time_s, p.px, p.py, p.vx, p.vy, p.grip_force_n, p.pull_x, p.pull_y, *hand,
                         float(np.asarray(p.grip_force_n) > 0.0)))
    return rec.run("ours", config.obj.pad_extent_x_m, config.obj.pad_extent_y_m)


def receiver_forces(sample: tuple, obj_state: tuple, hand_state: tuple, rp: ReceiverParams,
                    hand: HandParams) -> tuple[tuple[float, float], tuple[float, float], bool]:
    """A receiver's law at one instant, in our frame: (force of the hand on the object N,
    force on the hand N, the hand holds the object).

    sample: (r_x, r_y, ṙ_x, ṙ_y, grasp g, feedforward f_y) of `receiver.reference`;
    obj_state, hand_state: (x, y, v_x, v_y) in m, m/s. The grasp couples hand and object by
    g (k_c d + c_c ḋ) (full), only its part along u (along the pull), or a one-sided push
    along u (contact); the magnitude is capped at g × grasp strength (contact: the strength).
    The hand feels the impedance k_h (r − h) + d_h (ṙ − ḣ), the feedforward and the reaction."""
    rx, ry, rvx, rvy, g, ffy = sample
    px, py, vx, vy = obj_state
    hx, hy, hvx, hvy = hand_state
    kc, cc = hand.grasp_stiffness_n_per_m, hand.grasp_damping_n_s_per_m
    ux, uy = math.cos(rp.pull_angle_rad), math.sin(rp.pull_angle_rad)
    dx, dy, dvx, dvy = hx - px, hy - py, hvx - vx, hvy - vy
    fx, fy = g * (kc * dx + cc * dvx), g * (kc * dy + cc * dvy)
    coupling = int(rp.coupling)
    if coupling == Coupling.ALONG_PULL:
        along = fx * ux + fy * uy
        fx, fy = along * ux, along * uy
    elif coupling == Coupling.CONTACT:
        pen = dx * ux + dy * uy
        push = max(kc * pen + cc * (dvx * ux + dvy * uy), 0.0) if pen > 0.0 else 0.0
        fx, fy = push * ux, push * uy
    cap = rp.grasp_strength_n if coupling == Coupling.CONTACT else g * rp.grasp_strength_n
    mag = math.hypot(fx, fy)
    if mag > cap:
        fx, fy = fx * cap / mag, fy * cap / mag
    on_hand = (hand.stiffness_n_per_m * (rx - hx) + hand.damping_n_s_per_m * (rvx - hvx) - fx,
               hand.stiffness_n_per_m * (ry - hy) + hand.damping_n_s_per_m * (rvy - hvy) + ffy - fy)
    holds = coupling == Coupling.FULL and g >= hand.hold_grasp_level and math.hypot(dx, dy) < 0.02
    return (fx, fy), on_hand, holds


def run_mujoco(sc: Scenario, sim: SimConfig = SimConfig(), params: MujocoParams = MujocoParams(),
               mu: float | None = None) -> Run:
    """The scenario on MuJoCo; `mu` overrides the scenario's friction coefficient (to show
    that a wrong μ disagrees)."""
    obj = sc.object_params(sim.obj)
    dt = params.timestep_s
    n = int(round(sc.duration_s / dt))
    times = np.arange(n) * dt
    rp = sc.receiver
    ref = np.broadcast_arrays(*reference(times, rp)) if rp is not None else None
    hand_start = (float(ref[0][0]), float(ref[1][0])) if ref is not None else (0.5, 0.0)
    pinch = MujocoPinch(obj, sc.mu if mu is None else mu, params, sim.hand.mass_kg, hand_start)
    act = GripperActuator(sim.gripper, dt, ScalarBackend, 1, sc.grip[0][1])
    pinch.settle(act.spring_force_n())
    every = max(1, int(round(1.0 / (sim.gripper.loop_rate_hz * dt))))
    rec = _Recorder()
    for k in range(n):
        t = k * dt
        if k % every == 0:
            act.latch(grip_command_at(sc.grip, t))
        fg = act.spring_force_n()
        state = pinch.object_state()
        if rp is not None and ref is not None:
            sample = tuple(float(c[k]) for c in ref)
            f_obj, f_hand, holds = receiver_forces(sample, state, pinch.hand_state(), rp, sim.hand)
        else:
            f_obj, f_hand, holds = sc.hand_force_n(t), (0.0, 0.0), False
        pinch.step(fg, f_obj, f_hand)
        act.move()
        x, y, vx, vy = pinch.object_state()
        hx, hy = pinch.hand_state()[:2] if ref is not None else (math.nan, math.nan)
        rec.rows.append((pinch.time_s, x, y, vx, vy, fg, f_obj[0], f_obj[1], hx, hy, holds, pinch.pad_contacts()))
    return rec.run("mujoco", *pinch.footprint_m())
