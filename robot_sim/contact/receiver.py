"""Receiver behaviours: where the receiver's hand wants to be, and how hard it grasps.

The hand is not a force source: it is a mass on an impedance (see `HandParams`) that tracks
a reference r(t); the plant couples it to the object through the grasp. A behaviour is a
set of numbers (`ReceiverParams`), so a batch of episodes is the same dataclass holding
arrays of shape (n,).

Reference (gripper frame: x toward the receiver, y down; origin at the object's grasp
point; u = (cos φ, sin φ) the pull direction, φ > 0 pulls downward):

    r(t) = A (1 − s_reach(t)) + B s_pull(t) + C s_retract(t)
    g(t) = g_max s_grasp(t) (1 − s_letgo(t))

with s_*(t) minimum-jerk profiles 10τ³ − 15τ⁴ + 6τ⁵ over their windows, A the hand's start
offset, B = d_pull u the pull, C the retraction. The hand also pushes up with a feedforward
w_ff g(t) s_lift(t) Ŵ to carry the weight it expects (Ŵ, its estimate of the object's
weight); s_lift is 1 from t = 0 for every behaviour but the pull-first taking one, whose
lift window starts after its pull (or never: a drag).

Coupling of hand and object (`coupling`):
- FULL (taking, hesitating): spring–damper in x and y, scaled by g, capped at
  g × grasp_strength_n (the receiver's own fingers slip beyond that).
- ALONG_PULL (dropping: e.g. fingers inside a mug's handle): only the component along u
  is transmitted; the weight is not supported unless u is vertical.
- CONTACT (bumping): one-sided contact along u; the hand pushes, never pulls.

Behaviours (each seedable through `sample_behaviours`):
- taking: minimum-jerk reach, grasp builds over the transfer time (300–700 ms), weight
  feedforward, pull away along φ. The weight is taken up with the grasp, so before the pull
  has built up ("lift first").
- pull-first taking (`pull_first`): grasps and pulls as `taking`, but takes up the weight
  only some time after the pull started ("pull first, lift later"), or never (`drag`: a
  drag along φ that still takes the object, the hand holding it once it leaves the pads).
  Its `behaviour` is TAKING: handing it over is the right outcome.
- dropping: reach, grasp, pull (or push, φ near 180°) along φ without supporting the
  weight, then let go.
- bumping: the hand sweeps through the object's position along u at speed and retracts: a
  short collision impulse.
- hesitating: reach, grasp partly, then let go before taking the load, and retract.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from enum import IntEnum

import numpy as np

from robot_sim.contact.config import ContactSimError

__all__ = ["Behaviour", "Coupling", "ReceiverParams", "taking", "pull_first", "drag", "LiftOrder",
           "lift_order", "dropping", "bumping", "hesitating", "absent", "behaviour_by_name",
           "sample_behaviours", "stack_receivers", "reference", "min_jerk"]

NEVER_S = math.inf


class Behaviour(IntEnum):
    """Receiver behaviour kinds."""

    TAKING = 0
    DROPPING = 1
    BUMPING = 2
    HESITATING = 3
    ABSENT = 4


class Coupling(IntEnum):
    """How the hand transmits force to the object."""

    FULL = 0
    ALONG_PULL = 1
    CONTACT = 2


@dataclass(frozen=True)
class ReceiverParams:
    """One receiver behaviour (floats), or n of them (arrays of shape (n,)). Times in s,
    distances in m, forces in N, angles in rad; see the module docstring for the symbols.
    `lift_start_s`, `lift_duration_s`: the window of s_lift; the defaults (−1 s, 1 ms) make
    s_lift = 1 from t = 0 (the weight feedforward follows the grasp), inf never lifts."""

    behaviour: int
    coupling: int
    pull_angle_rad: float
    start_x_m: float
    start_y_m: float
    reach_start_s: float
    reach_duration_s: float
    pull_start_s: float
    pull_duration_s: float
    pull_distance_m: float
    retract_x_m: float
    retract_y_m: float
    retract_start_s: float
    retract_duration_s: float
    grasp_start_s: float
    grasp_build_s: float
    grasp_level: float
    letgo_start_s: float
    letgo_duration_s: float
    grasp_strength_n: float
    weight_feedforward: float
    weight_estimate_n: float
    lift_start_s: float = -1.0
    lift_duration_s: float = 1e-3

    def __post_init__(self) -> None:
        for f in fields(self):
            v = np.asarray(getattr(self, f.name), dtype=float)
            if np.isnan(v).any():
                raise ContactSimError(f"invalid receiver parameter: {f.name} is NaN")
        for n in ("reach_duration_s", "pull_duration_s", "retract_duration_s", "grasp_build_s", "letgo_duration_s",
                  "lift_duration_s"):
            if (np.asarray(getattr(self, n)) <= 0).any():
                raise ContactSimError(f"invalid receiver parameter: {n} must be > 0")
        level = np.asarray(self.grasp_level)
        if (np.asarray(self.grasp_strength_n) < 0).any() or ((level < 0) | (level > 1)).any():
            raise ContactSimError("invalid receiver parameter: grasp_strength_n must be >= 0 and grasp_level in [0, 1]")

    @property
    def n_episodes(self) -> int:
        """1 for a single behaviour, n for a stacked batch."""
        return int(np.size(self.pull_angle_rad))

    def episode(self, i: int) -> "ReceiverParams":
        """Behaviour i of a stacked batch, as floats."""
        return ReceiverParams(**{f.name: _item(getattr(self, f.name), i) for f in fields(self)})


def _item(v, i: int):
    a = np.asarray(v)
    return a.item() if a.ndim == 0 else a[i].item()


def taking(
    pull_angle_rad: float = 0.0,
    weight_n: float = 0.2 * 9.81,
    reach_start_s: float = 0.2,
    reach_duration_s: float = 0.8,
    reach_distance_m: float = 0.25,
    transfer_s: float = 0.5,
    pull_delay_s: float = 0.1,
    pull_duration_s: float = 0.8,
    pull_distance_m: float = 0.20,
    grasp_strength_n: float = 20.0,
    weight_feedforward: float = 1.0,
) -> ReceiverParams:
    """Reach, grasp over `transfer_s` (load transfer 0.3–0.7 s), carry the weight, pull along φ."""
    grasp_start = reach_start_s + reach_duration_s
    return ReceiverParams(
        behaviour=Behaviour.TAKING, coupling=Coupling.FULL, pull_angle_rad=pull_angle_rad,
        start_x_m=reach_distance_m, start_y_m=0.0,
        reach_start_s=reach_start_s, reach_duration_s=reach_duration_s,
        pull_start_s=grasp_start + pull_delay_s, pull_duration_s=pull_duration_s, pull_distance_m=pull_distance_m,
        retract_x_m=0.0, retract_y_m=0.0, retract_start_s=NEVER_S, retract_duration_s=0.5,
        grasp_start_s=grasp_start, grasp_build_s=transfer_s, grasp_level=1.0,
        letgo_start_s=NEVER_S, letgo_duration_s=0.1,
        grasp_strength_n=grasp_strength_n, weight_feedforward=weight_feedforward, weight_estimate_n=weight_n,
    )


def pull_first(
    pull_angle_rad: float = 0.0,
    weight_n: float = 0.2 * 9.81,
    reach_start_s: float = 0.2,
    reach_duration_s: float = 0.8,
    reach_distance_m: float = 0.25,
    transfer_s: float = 0.5,
    pull_delay_s: float = 0.0,
    pull_duration_s: float = 0.8,
    pull_distance_m: float = 0.20,
    lift_delay_s: float = 0.5,
    lift_duration_s: float = 0.4,
    grasp_strength_n: float = 20.0,
    weight_feedforward: float = 1.0,
) -> ReceiverParams:
    """A taking receiver who pulls first: reach and grasp as `taking`, pull along φ from
    `pull_delay_s` after the grasp starts, and take up the weight (the feedforward w_ff g Ŵ)
    only from `lift_delay_s` after the pull started, over `lift_duration_s`.
    `lift_delay_s = inf` never lifts (see `drag`)."""
    p = taking(pull_angle_rad=pull_angle_rad, weight_n=weight_n, reach_start_s=reach_start_s,
               reach_duration_s=reach_duration_s, reach_distance_m=reach_distance_m, transfer_s=transfer_s,
               pull_delay_s=pull_delay_s, pull_duration_s=pull_duration_s, pull_distance_m=pull_distance_m,
               grasp_strength_n=grasp_strength_n, weight_feedforward=weight_feedforward)
    if not lift_delay_s >= 0.0:
        raise ContactSimError(f"invalid receiver parameter: lift_delay_s must be >= 0, got {lift_delay_s}")
    return replace(p, lift_start_s=p.pull_start_s + lift_delay_s, lift_duration_s=lift_duration_s)


def drag(**kwargs) -> ReceiverParams:
    """A taking receiver who pulls along φ and never lifts: a drag that still takes the
    object (its grasp holds it once it leaves the pads). Arguments as `pull_first`, without
    the lift's."""
    return pull_first(**kwargs, lift_delay_s=NEVER_S)


class LiftOrder(IntEnum):
    """When a taking receiver takes up the weight relative to its pull."""

    LIFT_FIRST = 0
    PULL_FIRST = 1
    NEVER_LIFTS = 2


def lift_order(p: ReceiverParams):
    """`LiftOrder` code(s) of a receiver (an int, or an int array for a stacked batch): never
    lifts if its lift window never starts, pull first if it starts after the pull's."""
    start, pull = np.asarray(p.lift_start_s, dtype=float), np.asarray(p.pull_start_s, dtype=float)
    code = np.where(np.isinf(start) & (start > 0), LiftOrder.NEVER_LIFTS,
                    np.where(start > pull, LiftOrder.PULL_FIRST, LiftOrder.LIFT_FIRST)).astype(np.int64)
    return int(code) if code.ndim == 0 else code


def dropping(
    pull_angle_rad: float = 0.0,
    weight_n: float = 0.2 * 9.81,
    reach_start_s: float = 0.2,
    reach_duration_s: float = 0.8,
    reach_distance_m: float = 0.25,
    transfer_s: float = 0.3,
    pull_delay_s: float = 0.1,
    pull_duration_s: float = 0.8,
    pull_distance_m: float = 0.20,
    letgo_after_s: float = 1.5,
    grasp_strength_n: float = 20.0,
) -> ReceiverParams:
    """Reach, hook the object, pull (or push) along φ without carrying its weight, let go."""
    grasp_start = reach_start_s + reach_duration_s
    letgo = grasp_start + letgo_after_s
    u = (math.cos(pull_angle_rad), math.sin(pull_angle_rad))
    return ReceiverParams(
        behaviour=Behaviour.DROPPING, coupling=Coupling.ALONG_PULL, pull_angle_rad=pull_angle_rad,
        start_x_m=reach_distance_m, start_y_m=0.0,
        reach_start_s=reach_start_s, reach_duration_s=reach_duration_s,
        pull_start_s=grasp_start + pull_delay_s, pull_duration_s=pull_duration_s, pull_distance_m=pull_distance_m,
        retract_x_m=reach_distance_m - pull_distance_m * u[0], retract_y_m=-pull_distance_m * u[1],
        retract_start_s=letgo + 0.1, retract_duration_s=0.5,
        grasp_start_s=grasp_start, grasp_build_s=transfer_s, grasp_level=1.0,
        letgo_start_s=letgo, letgo_duration_s=0.1,
        grasp_strength_n=grasp_strength_n, weight_feedforward=0.0, weight_estimate_n=weight_n,
    )


def bumping(
    pull_angle_rad: float = math.pi,
    weight_n: float = 0.2 * 9.81,
    bump_start_s: float = 1.0,
    approach_distance_m: float = 0.05,
    penetration_m: float = 0.02,
    sweep_duration_s: float = 0.15,
) -> ReceiverParams:
    """The hand sweeps along u = (cos φ, sin φ) through the object's position and back.

    The default φ = π bumps the object toward the robot (the receiver's hand comes from
    the receiver's side). Contact starts when the hand passes the object's grasp point."""
    u = (math.cos(pull_angle_rad), math.sin(pull_angle_rad))
    travel = approach_distance_m + penetration_m
    return ReceiverParams(
        behaviour=Behaviour.BUMPING, coupling=Coupling.CONTACT, pull_angle_rad=pull_angle_rad,
        start_x_m=-approach_distance_m * u[0], start_y_m=-approach_distance_m * u[1],
        reach_start_s=NEVER_S, reach_duration_s=1.0,
        pull_start_s=bump_start_s, pull_duration_s=sweep_duration_s, pull_distance_m=travel,
        retract_x_m=-travel * u[0] - 0.2 * u[0], retract_y_m=-travel * u[1] - 0.2 * u[1],
        retract_start_s=bump_start_s + sweep_duration_s, retract_duration_s=0.4,
        grasp_start_s=-1.0, grasp_build_s=1e-3, grasp_level=1.0,
        letgo_start_s=NEVER_S, letgo_duration_s=0.1,
        grasp_strength_n=200.0, weight_feedforward=0.0, weight_estimate_n=weight_n,
    )


def hesitating(
    pull_angle_rad: float = 0.0,
    weight_n: float = 0.2 * 9.81,
    reach_start_s: float = 0.2,
    reach_duration_s: float = 0.8,
    reach_distance_m: float = 0.25,
    grasp_build_s: float = 0.3,
    grasp_level: float = 0.7,
    pull_distance_m: float = 0.01,
    letgo_after_s: float = 0.4,
    grasp_strength_n: float = 20.0,
) -> ReceiverParams:
    """Reach and grasp partly, tug a little, then let go before taking the load and retract."""
    grasp_start = reach_start_s + reach_duration_s
    letgo = grasp_start + letgo_after_s
    u = (math.cos(pull_angle_rad), math.sin(pull_angle_rad))
    return ReceiverParams(
        behaviour=Behaviour.HESITATING, coupling=Coupling.FULL, pull_angle_rad=pull_angle_rad,
        start_x_m=reach_distance_m, start_y_m=0.0,
        reach_start_s=reach_start_s, reach_duration_s=reach_duration_s,
        pull_start_s=grasp_start + 0.05, pull_duration_s=0.3, pull_distance_m=pull_distance_m,
        retract_x_m=reach_distance_m - pull_distance_m * u[0], retract_y_m=-pull_distance_m * u[1],
        retract_start_s=letgo + 0.1, retract_duration_s=0.5,
        grasp_start_s=grasp_start, grasp_build_s=grasp_build_s, grasp_level=grasp_level,
        letgo_start_s=letgo, letgo_duration_s=0.1,
        grasp_strength_n=grasp_strength_n, weight_feedforward=0.0, weight_estimate_n=weight_n,
    )


def absent(weight_n: float = 0.2 * 9.81) -> ReceiverParams:
    """No receiver: the hand stays away and never touches the object (plant tests)."""
    return ReceiverParams(
        behaviour=Behaviour.ABSENT, coupling=Coupling.FULL, pull_angle_rad=0.0,
        start_x_m=0.5, start_y_m=0.0, reach_start_s=NEVER_S, reach_duration_s=1.0,
        pull_start_s=NEVER_S, pull_duration_s=1.0, pull_distance_m=0.0,
        retract_x_m=0.0, retract_y_m=0.0, retract_start_s=NEVER_S, retract_duration_s=1.0,
        grasp_start_s=NEVER_S, grasp_build_s=1.0, grasp_level=0.0,
        letgo_start_s=NEVER_S, letgo_duration_s=1.0,
        grasp_strength_n=0.0, weight_feedforward=0.0, weight_estimate_n=weight_n,
    )


#: The behaviours of the first benchmark ("mixed" draws one of these four, in this order).
_FACTORIES = {"taking": taking, "dropping": dropping, "bumping": bumping, "hesitating": hesitating}
#: The taking receivers who pull before (or without) lifting.
_PULL_FIRST_FACTORIES = {"pull-first": pull_first, "drag": drag}


def behaviour_by_name(name: str, **kwargs) -> ReceiverParams:
    """Build a behaviour from its name (taking, pull-first, drag, dropping, bumping,
    hesitating, absent)."""
    factories = {**_FACTORIES, **_PULL_FIRST_FACTORIES, "absent": absent}
    try:
        factory = factories[name]
    except KeyError:
        raise ContactSimError(f"unknown receiver behaviour {name!r}; choose one of {sorted(factories)}") from None
    return factory(**kwargs)


def sample_behaviours(kind: str, n: int, rng: np.random.Generator,
                      weight_n: float = 0.2 * 9.81) -> list[ReceiverParams]:
    """n randomised behaviours of one kind, "mixed" or "mixed-wide": see
    `robot_sim.contact.sampling.sample_behaviours` (the distributions are there)."""
    from robot_sim.contact.sampling import sample_behaviours as sample

    return sample(kind, n, rng, weight_n=weight_n)


def stack_receivers(behaviours: list[ReceiverParams]) -> ReceiverParams:
    """Stack n behaviours into one `ReceiverParams` of arrays of shape (n,)."""
    if not behaviours:
        raise ContactSimError("need at least one receiver behaviour")
    cols = {f.name: np.array([float(getattr(b, f.name)) for b in behaviours]) for f in fields(ReceiverParams)}
    cols["behaviour"] = cols["behaviour"].astype(np.int64)
    cols["coupling"] = cols["coupling"].astype(np.int64)
    return ReceiverParams(**cols)


def min_jerk(t, start_s, duration_s):
    """Minimum-jerk profile s(t) ∈ [0, 1] and its rate ds/dt (1/s) over [start, start + duration]."""
    tau = np.clip((t - start_s) / duration_s, 0.0, 1.0)
    tau2 = tau * tau
    s = tau2 * tau * (10.0 - 15.0 * tau + 6.0 * tau2)
    ds = 30.0 * tau2 * (1.0 - tau) ** 2 / duration_s
    return s, ds


def reference(t, p: ReceiverParams):
    """Hand reference, grasp level and weight feedforward at time(s) t.

    `t` and the fields of `p` broadcast (t an array with p floats gives a time series;
    t a float with p stacked gives one value per episode). Returns
    (r_x, r_y, rdot_x, rdot_y, grasp, feedforward_y): positions (m), velocities (m/s),
    grasp level in [0, 1], feedforward force on the hand along y (N, negative = upward).
    """
    ux, uy = np.cos(p.pull_angle_rad), np.sin(p.pull_angle_rad)
    s1, d1 = min_jerk(t, p.reach_start_s, p.reach_duration_s)
    s2, d2 = min_jerk(t, p.pull_start_s, p.pull_duration_s)
    s3, d3 = min_jerk(t, p.retract_start_s, p.retract_duration_s)
    bx, by = p.pull_distance_m * ux, p.pull_distance_m * uy
    rx = p.start_x_m * (1.0 - s1) + bx * s2 + p.retract_x_m * s3
    ry = p.start_y_m * (1.0 - s1) + by * s2 + p.retract_y_m * s3
    rvx = -p.start_x_m * d1 + bx * d2 + p.retract_x_m * d3
    rvy = -p.start_y_m * d1 + by * d2 + p.retract_y_m * d3
    sg, _ = min_jerk(t, p.grasp_start_s, p.grasp_build_s)
    sl, _ = min_jerk(t, p.letgo_start_s, p.letgo_duration_s)
    lift, _ = min_jerk(t, p.lift_start_s, p.lift_duration_s)
    grasp = p.grasp_level * sg * (1.0 - sl)
    ff_y = -p.weight_feedforward * grasp * p.weight_estimate_n * lift
    return rx, ry, rvx, rvy, grasp, ff_y


def with_overrides(p: ReceiverParams, **changes) -> ReceiverParams:
    """A copy of `p` with some fields changed."""
    return replace(p, **changes)
