"""What MuJoCo's soft contact does that our plant does not: how fast a stuck box creeps, how
far the pads sink, and whether the pads chatter while the box slides (the docs quote these).

Our gripper frame (x toward the receiver, y DOWN), SI units; the default object (0.2 kg,
μ = 0.6, pads 4 cm × 3 cm) unless given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from robot_sim.contact.config import ObjectParams
from robot_sim.contact.crosscheck.mjcf import MUJOCO_DEFAULT_SOLIMP, MujocoParams, MujocoPinch

__all__ = ["creep", "SlideContact", "slide_contact", "diagnostics_lines"]


def creep(params: MujocoParams = MujocoParams(), grip_n: float = 10.0, cone_fraction: float | None = None,
          obj: ObjectParams = ObjectParams(), duration_s: float = 1.0) -> tuple[float, float]:
    """(creep speed m/s, pad sink m) of a stuck box after `duration_s` under `grip_n` (N per
    pad): under its weight alone, or with a horizontal pull bringing the load to
    `cone_fraction` of μ F_G."""
    pinch = MujocoPinch(obj, obj.mu_static, params)
    pinch.settle(grip_n)
    limit, w = obj.mu_static * grip_n, obj.weight_n
    pull = 0.0 if cone_fraction is None else math.sqrt(max((cone_fraction * limit) ** 2 - w * w, 0.0))
    for _ in range(int(round(duration_s / params.timestep_s))):
        pinch.step(grip_n, (pull, 0.0))
    _, _, vx, vy = pinch.object_state()
    sink = float(pinch.data.qpos[pinch.model.jnt_qposadr[pinch.model.joint("pad_l").id]])
    return math.hypot(vx, vy), sink


@dataclass(frozen=True)
class SlideContact:
    """A box sliding between the pads: the share of steps with no pad contact, the normal
    force's standard deviation over its mean, and the mean friction over μ × mean normal."""

    lost_share: float
    normal_spread: float
    friction_ratio: float


def slide_contact(params: MujocoParams = MujocoParams(), grip_n: float = 10.0, pull_n: float = 6.5,
                  obj: ObjectParams = ObjectParams()) -> SlideContact:
    """Pull the box out along x (`pull_n` N > the cone) and look at the contact while it is
    between 2 mm and 35 mm along."""
    pinch = MujocoPinch(obj, obj.mu_static, params)
    pinch.settle(grip_n)
    samples = []
    for k in range(int(round(0.4 / params.timestep_s))):
        pinch.step(grip_n, (pull_n if k * params.timestep_s >= 0.05 else 0.0, 0.0))
        x = pinch.object_state()[0]
        if 0.002 < x < 0.035:
            samples.append((pinch.pad_contacts(), *pinch.pad_forces_n()))
    a = np.array(samples)
    normal = a[:, 1]
    return SlideContact(lost_share=float(np.mean(a[:, 0] == 0)), normal_spread=float(normal.std() / normal.mean()),
                        friction_ratio=float(a[:, 2].mean() / (obj.mu_static / 2 * normal.mean())))


def diagnostics_lines(params: MujocoParams = MujocoParams()) -> list[str]:
    """The docs' MuJoCo figures as printable lines (default model, 10 N grip)."""
    w_only, sink = creep(params)
    edge = creep(params, grip_n=1.03 * ObjectParams().weight_n / ObjectParams().mu_static)[0]
    near = creep(params, cone_fraction=0.95)[0]
    lines = [f"MuJoCo pads sink {1e3 * sink:.2f} mm at 10 N; a stuck box creeps {1e3 * w_only:.3f} mm/s under its "
             f"weight, {1e3 * edge:.3f} mm/s at F_G = 1.03 W/mu, {1e3 * near:.3f} mm/s at 95 % of the cone"]
    slower = ", ".join(f"{1e3 * creep(replace(params, impratio=r), cone_fraction=0.95)[0]:.2f} mm/s with impratio {r:g}"
                       for r in (1.0, 10.0))
    lines.append(f"at 95 % of the cone a stuck box creeps {slower}")
    default_solimp = replace(params, solimp=MUJOCO_DEFAULT_SOLIMP)
    for label, p in (("this model", params), ("MuJoCo's default solimp", default_solimp)):
        s = slide_contact(p)
        lines.append(f"sliding, {label}: no pad contact in {100 * s.lost_share:.0f} % of steps, normal force "
                     f"spread {100 * s.normal_spread:.0f} %, mean friction {s.friction_ratio:.3f} mu N")
    return lines
