"""The cross-check's cases: slip onset over a grid, slides under a grip ramp-down, catches by
a regrasp, receiver behaviours (drop or not), and the known modelling differences.

Gripper frame (x toward the receiver, y DOWN; φ > 0 pulls downward), SI units. The grip
commands go through our actuator model (25 Hz loop, 50 N/s), the same on both plants.
"""

from __future__ import annotations

import math
from dataclasses import replace

from robot_sim.contact.config import GRAVITY_M_S2
from robot_sim.contact.crosscheck.compare import Case
from robot_sim.contact.crosscheck.mjcf import MUJOCO_DEFAULT_SOLIMP, MujocoParams
from robot_sim.contact.crosscheck.scenario import Scenario
from robot_sim.contact.receiver import absent, bumping, dropping, hesitating, taking

__all__ = ["onset_grid", "slide_cases", "receiver_cases", "difference_cases", "mujoco_variants", "all_cases",
           "quick_cases"]

#: Grip of the slip-onset grid (N): μ F_G exceeds the weight for every mass and μ of the grid.
ONSET_GRIP_N = 15.0
#: Pull ramp of the slip-onset grid (N/s) and when it starts (s).
ONSET_RATE_N_S = 5.0
ONSET_START_S = 0.2
#: The slide scenarios: the grip command drops from this (N) to 0 at `RELEASE_AT_S` (s).
HOLD_N = 10.0
RELEASE_AT_S = 0.3


def onset_case(mass_kg: float, mu: float, phi_deg: float, support: bool, grip_n: float = ONSET_GRIP_N,
               group: str = "slip onset") -> Case:
    """Ramp the pull along φ at `ONSET_RATE_N_S` under a fixed grip until the object slides."""
    base = Scenario("probe", "onset", mass_kg=mass_kg, mu=mu, grip=((0.0, grip_n),),
                    pull_angle_rad=math.radians(phi_deg), pull_rate_n_s=ONSET_RATE_N_S,
                    pull_start_s=ONSET_START_S, support=support)
    onset = base.onset_pull_n(grip_n)
    if not math.isfinite(onset) or onset <= 0.0:
        raise ValueError(f"no slip onset under a pull for M={mass_kg}, mu={mu}, phi={phi_deg}, grip={grip_n}")
    angle = f"{phi_deg:+g}°".replace("-", "−") if phi_deg else "0°"
    name = f"M {mass_kg:g} kg, μ {mu:g}, φ {angle}, {'supported' if support else 'unsupported'}"
    return Case(replace(base, name=name, duration_s=ONSET_START_S + onset / ONSET_RATE_N_S + 0.25), group)


def onset_grid() -> list[Case]:
    """72 cases: M ∈ {0.1, 0.2, 0.4} kg × μ ∈ {0.3, 0.6, 1.0} × φ ∈ {−30, 0, 30, 60}° ×
    weight supported by the hand or not; grip 15 N."""
    return [onset_case(m, mu, phi, sup) for m in (0.1, 0.2, 0.4) for mu in (0.3, 0.6, 1.0)
            for phi in (-30.0, 0.0, 30.0, 60.0) for sup in (False, True)]


def _slide(name: str, pull_n: float = 0.0, phi_deg: float = 0.0, support: bool = False, mass_kg: float = 0.2,
           mu: float = 0.6, regrasp_at_s: float | None = None, group: str = "slide") -> Case:
    grip: tuple[tuple[float, float], ...] = ((0.0, HOLD_N), (RELEASE_AT_S, 0.0))
    if regrasp_at_s is not None:
        grip += ((regrasp_at_s, HOLD_N),)
    return Case(Scenario(name, "slide", mass_kg=mass_kg, mu=mu, grip=grip, pull_angle_rad=math.radians(phi_deg),
                         pull_n=pull_n, pull_start_s=0.0, support=support, duration_s=1.0), group)


def slide_cases() -> list[Case]:
    """The grip command drops from 10 N to 0 at 0.3 s (the actuator ramps at 50 N/s) under a
    constant pull: where it starts to slide, when it leaves the pads; and regrasps to 10 N at
    0.44–0.52 s: caught, or gone."""
    return [
        _slide("weight only"),
        _slide("2 N along 0°", 2.0),
        _slide("2 N along 0°, supported", 2.0, support=True),
        _slide("2 N along +30°", 2.0, 30.0),
        _slide("2 N along −30°", 2.0, -30.0),
        _slide("2 N along +30°, supported", 2.0, 30.0, support=True),
        _slide("μ 1.0, 2 N along 0°", 2.0, mu=1.0),
        _slide("M 0.4 kg, 2 N along 0°", 2.0, mass_kg=0.4),
        _slide("regrasp at 0.44 s", regrasp_at_s=0.44, group="catch"),
        _slide("regrasp at 0.48 s", regrasp_at_s=0.48, group="catch"),
        _slide("regrasp at 0.52 s", regrasp_at_s=0.52, group="catch"),
        _slide("regrasp at 0.48 s, 1 N along 0°", 1.0, regrasp_at_s=0.48, group="catch"),
        _slide("regrasp at 0.44 s, 2 N along +30°", 2.0, 30.0, regrasp_at_s=0.44, group="catch"),
    ]


def _receiver(name: str, receiver, grip, mass_kg: float = 0.2, duration_s: float = 3.0) -> Case:
    return Case(Scenario(name, "receiver", mass_kg=mass_kg, grip=grip, receiver=receiver, duration_s=duration_s),
                "receiver")


def receiver_cases() -> list[Case]:
    """Receivers of our plant (`robot_sim.contact.receiver`) with open-loop grips: does the
    object drop? Includes a hold under gravity alone just above and below μ F_G = M g."""
    edge = 0.2 * GRAVITY_M_S2 / 0.6
    return [
        _receiver("no receiver, grip 1.03 W/μ", absent(), ((0.0, 1.03 * edge),), duration_s=2.0),
        _receiver("no receiver, grip 0.97 W/μ", absent(), ((0.0, 0.97 * edge),), duration_s=2.0),
        _receiver("taking φ 0°, 10 N", taking(), ((0.0, 10.0),)),
        _receiver("taking φ +30°, 10 N", taking(math.radians(30.0)), ((0.0, 10.0),)),
        _receiver("taking φ 0°, release at 1.25 s", taking(), ((0.0, 10.0), (1.25, 0.0))),
        _receiver("taking 0.4 kg, φ −20°, 15 N", taking(math.radians(-20.0), weight_n=0.4 * GRAVITY_M_S2),
                  ((0.0, 15.0),), mass_kg=0.4),
        _receiver("dropping φ 0°, release at 1.2 s", dropping(), ((0.0, 10.0), (1.2, 0.0))),
        _receiver("dropping φ 0°, 10 N", dropping(), ((0.0, 10.0),)),
        _receiver("dropping φ 0°, 40 N", dropping(), ((0.0, 40.0),)),
        _receiver("hesitating, 10 N", hesitating(), ((0.0, 10.0),)),
        _receiver("bumping, 10 N", bumping(), ((0.0, 10.0),), duration_s=2.0),
    ]


_MU_K_NOTE = ("ours with its default μ_k = 0.5 < μ_s = 0.6; MuJoCo has one coefficient (0.6): the onset agrees, "
              "the slide is faster in ours")


def difference_cases() -> list[Case]:
    """Known differences (expected to disagree: our μ_k < μ_s, a wrong μ in MuJoCo) and the
    MuJoCo settings tried (`mujoco_variants`)."""
    mu_k = [replace(c, scenario=replace(c.scenario, name=c.scenario.name + ", ours μ_k 0.5", ours_mu_kinetic=0.5),
                    group="μ_k < μ_s (ours)", expect_agree=False, note=_MU_K_NOTE)
            for c in (_slide("2 N along 0°", 2.0), _slide("regrasp at 0.48 s", regrasp_at_s=0.48),
                      _receiver("dropping φ 0°, 10 N", dropping(), ((0.0, 10.0),)))]
    wrong = onset_case(0.2, 0.6, 0.0, False, group="wrong μ in MuJoCo")
    wrong = replace(wrong, scenario=replace(wrong.scenario, name=wrong.scenario.name + ", MuJoCo μ 0.48"),
                    mujoco_mu=0.48, expect_agree=False, note="MuJoCo given μ = 0.8 × 0.6: the check must catch it")
    return mu_k + [wrong] + mujoco_variants()


#: MuJoCo settings tried against the defaults: (group, parameters, expect agreement, note,
#: on the slide too or only on the dropping receiver).
_VARIANTS = (
    ("MuJoCo box free to rotate", MujocoParams(free_rotation=True), True, "", True),
    ("MuJoCo at dt = 0.5 ms", MujocoParams(timestep_s=0.0005), True, "", True),
    ("MuJoCo with no-slip solver", MujocoParams(noslip_iterations=2), True, "", True),
    ("MuJoCo impratio 10", MujocoParams(impratio=10.0), False,
     "a stuck box creeps faster than the 1 mm/s slip detector near the cone: onset read early", True),
    ("MuJoCo's default solimp", MujocoParams(solimp=MUJOCO_DEFAULT_SOLIMP), False,
     "a hard contact chatters while sliding (the pads bounce): the hand-force peak is higher", False),
)


def mujoco_variants() -> list[Case]:
    """Each MuJoCo setting of `_VARIANTS` on a dropping receiver (and a slide)."""
    out = []
    for label, params, agree, note, with_slide in _VARIANTS:
        cases = [_receiver("dropping φ 0°, 10 N", dropping(), ((0.0, 10.0),))]
        if with_slide:
            cases.insert(0, _slide("2 N along +30°", 2.0, 30.0))
        for c in cases:
            out.append(replace(c, scenario=replace(c.scenario, name=f"{c.scenario.name} ({label})"), group=label,
                               mujoco=params, expect_agree=agree, note=note))
    return out


def all_cases() -> list[Case]:
    """Every case of the docs' table."""
    return onset_grid() + slide_cases() + receiver_cases() + difference_cases()


def quick_cases() -> list[Case]:
    """A few cases that run in about a second on both plants (CI, `--quick`)."""
    return [onset_case(0.2, 0.6, 30.0, False), onset_case(0.4, 1.0, -30.0, True),
            _slide("2 N along +30°", 2.0, 30.0), _slide("regrasp at 0.48 s", regrasp_at_s=0.48, group="catch"),
            _receiver("dropping φ 0°, release at 1.2 s", dropping(), ((0.0, 10.0), (1.2, 0.0)))]
