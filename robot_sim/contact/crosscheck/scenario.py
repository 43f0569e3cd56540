"""Cross-check scenarios: what both plants are given (object, grip-command schedule, the
hand), written once and run on each plant (`robot_sim.contact.crosscheck.runs`).

Gripper frame as in `robot_sim.contact.plant`: x toward the receiver, y DOWN; the pull
direction u = (cos φ, sin φ), φ > 0 pulls downward. SI units.

Two kinds of hand:
- a **prescribed force** on the object: F_hand(t) = F_p(t) u − s (0, W), with
  F_p(t) = pull_n + pull_rate_n_s · max(0, t − pull_start_s) and s = 1 when the hand
  supports the weight W = M g (`support`), else 0;
- a **receiver** of our plant (`robot_sim.contact.receiver.ReceiverParams`): a hand mass on
  an impedance around r(t), coupled to the object by its grasp (both plants apply the same
  law; the physics of pads and object is each plant's own).

Friction: MuJoCo has one coefficient, our plant a static μ_s and a kinetic μ_k. A scenario
gives both plants the same μ (our μ_k = μ_s = μ) unless `ours_mu_kinetic` sets a different
μ_k for our plant (the rows that show what μ_k < μ_s changes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from robot_sim.contact.config import GRAVITY_M_S2, ContactSimError, ObjectParams
from robot_sim.contact.receiver import ReceiverParams

__all__ = ["Scenario", "grip_command_at"]

#: Kinds of scenario, each with its own measured quantities (`measure`).
KINDS = ("onset", "slide", "receiver")


@dataclass(frozen=True)
class Scenario:
    """One cross-check case.

    name: a short unique label. kind: "onset" (ramp the pull at a fixed grip: where does the
        object start to slide), "slide" (a grip schedule under a constant pull: how far does
        it slide, does it leave the pads or get caught) or "receiver" (a receiver behaviour:
        dropped or not).
    mass_kg, mu: the object's mass and the total friction coefficient of both pads.
    ours_mu_kinetic: our plant's μ_k if not μ (None: μ_k = μ_s = μ).
    grip: the grip-command schedule ((from time s, command N), ...) sorted by time; the first
        entry's command is also the settled grip force at t = 0.
    pull_angle_rad, pull_n, pull_rate_n_s, pull_start_s, support: the prescribed hand force
        (module docstring); unused when `receiver` is set.
    receiver: a receiver behaviour of our plant instead of a prescribed force.
    duration_s: how long both plants run (s).
    """

    name: str
    kind: str
    mass_kg: float = 0.2
    mu: float = 0.6
    ours_mu_kinetic: float | None = None
    grip: tuple[tuple[float, float], ...] = ((0.0, 10.0),)
    pull_angle_rad: float = 0.0
    pull_n: float = 0.0
    pull_rate_n_s: float = 0.0
    pull_start_s: float = 0.2
    support: bool = False
    receiver: ReceiverParams | None = None
    duration_s: float = 2.0

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ContactSimError(f"scenario {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}")
        times = [t for t, _ in self.grip]
        if not self.grip or times != sorted(times) or any(f < 0 or not math.isfinite(f) for _, f in self.grip):
            raise ContactSimError(f"scenario {self.name!r}: grip must be a time-sorted schedule of forces >= 0")
        if self.kind == "receiver" and self.receiver is None:
            raise ContactSimError(f"scenario {self.name!r}: a receiver scenario needs a receiver")
        if not (self.mass_kg > 0 and self.mu > 0 and self.duration_s > 0):
            raise ContactSimError(f"scenario {self.name!r}: mass, mu and duration must be > 0")

    @property
    def weight_n(self) -> float:
        """W = M g (N)."""
        return self.mass_kg * GRAVITY_M_S2

    def object_params(self, base: ObjectParams = ObjectParams()) -> ObjectParams:
        """Our plant's object for this scenario (pad extents from `base`)."""
        mu_k = self.mu if self.ours_mu_kinetic is None else self.ours_mu_kinetic
        return replace(base, mass_kg=self.mass_kg, mu_static=self.mu, mu_kinetic=mu_k)

    def pull_n_at(self, t_s: float) -> float:
        """Prescribed pull magnitude F_p(t) along u (N)."""
        return self.pull_n + self.pull_rate_n_s * max(0.0, t_s - self.pull_start_s)

    def hand_force_n(self, t_s: float) -> tuple[float, float]:
        """Prescribed force of the hand on the object at time t (N, x and y down)."""
        f = self.pull_n_at(t_s)
        support = self.weight_n if self.support else 0.0
        return f * math.cos(self.pull_angle_rad), f * math.sin(self.pull_angle_rad) - support

    def onset_pull_n(self, grip_force_n: float) -> float:
        """Coulomb's slip onset for a prescribed pull: the F_p at which the external force's
        magnitude |F_p u + (0, W (1 − s))| reaches μ F_G (N); NaN if it never does (a pull
        that cannot reach the cone) and 0 if the object slides with no pull."""
        limit = self.mu * grip_force_n
        w = 0.0 if self.support else self.weight_n
        if w > limit:
            return 0.0
        s = math.sin(self.pull_angle_rad)
        # |F u + (0, w)|² = F² + 2 F w sin φ + w² = limit²: the positive root.
        disc = (w * s) ** 2 - (w * w - limit * limit)
        return -w * s + math.sqrt(disc) if disc >= 0 else math.nan


def grip_command_at(schedule: tuple[tuple[float, float], ...], t_s: float) -> float:
    """The grip command (N) of a schedule at time t (s): the last entry whose time is ≤ t."""
    cmd = schedule[0][1]
    for start, force in schedule:
        if t_s >= start:
            cmd = force
        else:
            break
    return cmd
