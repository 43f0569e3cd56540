"""The evaluation's population: receivers and objects drawn from DECLARED distributions.

Every quantity the simulated stack lets a profile vary is one `Variable`: its name, unit, the
distribution in words, where the distribution comes from, and how it is drawn. Each variable
of each episode has its own random stream, ``SeedSequence(entropy=run_seed,
spawn_key=(episode, variable index))``: the same run seed gives the same population, and
changing one distribution does not move the draws of the others.

What the simulation cannot vary today is listed in `NOT_VARIED` with the reason (the report
and docs/evaluation.md print it): an evaluation must not claim to cover what it never drew.

Units: SI with the unit in the name (m, kg, s, N, deg); positions in the scene's `base` frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

#: Receiver behaviours and their weights in the default population (an evaluation design
#: choice, not a published frequency: most receivers take the object; each kind of failure
#: the stack must survive appears in one episode in ten).
BEHAVIOUR_WEIGHTS: dict[str, float] = {
    "taking": 0.6, "dropping": 0.1, "hesitating": 0.1, "bumping": 0.1, "absent": 0.1,
}
#: Share of sitting receivers (design choice: the thesis's two postures, §2.5).
SITTING_SHARE = 0.3
#: Adult stature by sex, mean and standard deviation, m: CDC NHANES 2015–2018, adults 20+
#: (Fryar et al., Anthropometric reference data for children and adults: United States,
#: 2015–2018, Vital Health Stat 3(46), 2021): men 175.4 cm, women 161.5 cm, SD ≈ 7–8 cm.
STATURE_M = {"men": (1.754, 0.076), "women": (1.615, 0.071)}
#: Stature is truncated to this range, m (about the 0.1st–99.9th percentiles of the mixture,
#: inside the bridge's 1.2–2.2 m).
STATURE_RANGE_M = (1.45, 2.00)
#: Body-mass index, log-normal: median and log-SD, and the truncation range, kg/m² (NHANES
#: 2015–2018 adults: mean BMI ≈ 29.6; a median of 28 with a log-SD of 0.2 matches its spread).
BMI_MEDIAN_KG_M2, BMI_LOG_SD, BMI_RANGE_KG_M2 = 28.0, 0.2, (18.0, 45.0)


@dataclass(frozen=True)
class Variable:
    """One drawn quantity: `draw(rng, drawn_so_far)` returns its value."""

    name: str
    unit: str
    distribution: str
    source: str
    draw: Callable[[np.random.Generator, dict[str, Any]], Any]


def _truncated_normal(rng: np.random.Generator, mean: float, sd: float, lo: float, hi: float) -> float:
    """A normal draw redrawn until it falls in [lo, hi] (the truncated normal)."""
    while True:
        value = float(rng.normal(mean, sd))
        if lo <= value <= hi:
            return value


def _stature(rng: np.random.Generator, _drawn: dict[str, Any]) -> float:
    mean, sd = STATURE_M["men" if rng.random() < 0.5 else "women"]
    return round(_truncated_normal(rng, mean, sd, *STATURE_RANGE_M), 4)


def _weight(rng: np.random.Generator, drawn: dict[str, Any]) -> float:
    lo, hi = BMI_RANGE_KG_M2
    bmi = math.exp(_truncated_normal(rng, math.log(BMI_MEDIAN_KG_M2), BMI_LOG_SD, math.log(lo), math.log(hi)))
    return round(bmi * drawn["height_m"] ** 2, 2)


def _choice(weights: dict[str, float]) -> Callable[[np.random.Generator, dict[str, Any]], str]:
    names, p = list(weights), np.array(list(weights.values()), dtype=float)
    return lambda rng, _drawn: str(names[int(rng.choice(len(names), p=p / p.sum()))])


def _uniform(lo: float, hi: float, digits: int = 4) -> Callable[[np.random.Generator, dict[str, Any]], float]:
    return lambda rng, _drawn: round(float(rng.uniform(lo, hi)), digits)


def _log_uniform(lo: float, hi: float) -> Callable[[np.random.Generator, dict[str, Any]], float]:
    return lambda rng, _drawn: round(float(math.exp(rng.uniform(math.log(lo), math.log(hi)))), 4)


def _mu_kinetic(rng: np.random.Generator, drawn: dict[str, Any]) -> float:
    return round(drawn["mu_static"] * float(rng.uniform(0.7, 0.9)), 4)


#: Receiver parameters per behaviour (`robot_sim.contact.receiver`): name → (lo, hi), drawn
#: uniformly. Taking: reaction delay from grasp to pull, and the load-transfer time 0.3–0.7 s
#: (Chan et al., cited in the thesis §3.2). Dropping: reaction delay, and when it lets go.
#: Hesitating: when it lets go of its partial grasp. Bumping: how long the sweep lasts.
BEHAVIOUR_PARAMETERS: dict[str, dict[str, tuple[float, float]]] = {
    "taking": {"pull_delay_s": (0.05, 0.30), "transfer_s": (0.3, 0.7)},
    "dropping": {"pull_delay_s": (0.05, 0.30), "letgo_after_s": (1.0, 2.0)},
    "hesitating": {"letgo_after_s": (0.2, 0.6)},
    "bumping": {"sweep_duration_s": (0.10, 0.25)},
    "absent": {},
}


def _receiver(rng: np.random.Generator, drawn: dict[str, Any]) -> dict[str, float]:
    return {name: round(float(rng.uniform(lo, hi)), 4)
            for name, (lo, hi) in BEHAVIOUR_PARAMETERS[drawn["behaviour"]].items()}


def _seed(rng: np.random.Generator, _drawn: dict[str, Any]) -> int:
    return int(rng.integers(0, 2**32))


#: The default population, in draw order (a variable may read the ones before it).
VARIABLES: tuple[Variable, ...] = (
    Variable("height_m", "m", "50/50 mixture of N(1.754, 0.076) (men) and N(1.615, 0.071) (women), "
             "truncated to 1.45–2.00", "CDC NHANES 2015–2018 adults (Fryar et al. 2021)", _stature),
    Variable("weight_kg", "kg", "BMI × height², BMI log-normal (median 28, log-SD 0.2) truncated to 18–45",
             "NHANES 2015–2018 BMI (mean ≈ 29.6 kg/m²)", _weight),
    Variable("posture", "", f"sitting with probability {SITTING_SHARE}, else standing",
             "design choice (thesis §2.5 studies both)",
             _choice({"standing": 1.0 - SITTING_SHARE, "sitting": SITTING_SHARE})),
    Variable("behaviour", "", ", ".join(f"{k} {v:.0%}" for k, v in BEHAVIOUR_WEIGHTS.items()),
             "design choice (the behaviours of DESIGN §7)", _choice(BEHAVIOUR_WEIGHTS)),
    Variable("receiver", "s", "per behaviour, uniform: " + "; ".join(
        f"{b}: " + ", ".join(f"{n} {lo}–{hi}" for n, (lo, hi) in p.items())
        for b, p in BEHAVIOUR_PARAMETERS.items() if p),
        "load transfer 0.3–0.7 s: Chan et al. (thesis §3.2); the other ranges are assumptions", _receiver),
    Variable("hand_reach_duration_s", "s", "uniform 0.6–1.4",
             "assumption around the scene's 1.0 s and the plant's 0.8 s reach", _uniform(0.6, 1.4)),
    Variable("pull_angle_deg", "deg", "uniform −20 to 20 (> 0 pulls downward)",
             "assumption (thesis Fig. 21 studies pull angles)", _uniform(-20.0, 20.0, 2)),
    Variable("object_mass_kg", "kg", "log-uniform 0.1–0.5",
             "assumption: hand-held everyday objects (the thesis's mug: 0.2 kg)", _log_uniform(0.1, 0.5)),
    Variable("mu_static", "", "uniform 0.4–1.0", "assumption (thesis Table IV: 0.6)", _uniform(0.4, 1.0)),
    Variable("mu_kinetic", "", "μ_s × uniform 0.7–0.9", "assumption (thesis Table IV: 0.5 for μ_s 0.6)",
             _mu_kinetic),
    Variable("ft_noise_std_n", "N", "uniform 0.01–0.10", "assumption (simulator default 0.03)",
             _uniform(0.01, 0.10)),
    Variable("ft_bias_std_n", "N", "uniform 0.00–0.20", "assumption (simulator default 0.05)",
             _uniform(0.0, 0.20)),
    Variable("sim_seed", "", "uniform integer 0–2³²−1",
             "the plant's and the simulated Kinect's noise (skeleton jitter, depth)", _seed),
)

#: What the population does not vary, and why (printed in the report and the docs).
NOT_VARIED: tuple[tuple[str, str], ...] = (
    ("position and orientation relative to the robot",
     "the scene places the receiver's receiving shoulder in the task plane 1.0 m from the robot's, facing it "
     "(handover_model.scene); the planner, tracker and simulated Kinect share that placement"),
    ("arm length apart from height",
     "the simulated body's arm span equals its height (handover_model.body.AVERAGE_SPAN_TO_HEIGHT)"),
    ("hand height", "follows from the body, the posture and the reach to the presented object"),
    ("skeleton noise level", "fixed in the simulated Kinect's model (its seed is drawn: sim_seed)"),
)


@dataclass(frozen=True)
class EpisodeDraw:
    """One episode's receiver, object and noise (see `VARIABLES` for units and sources)."""

    episode: int
    height_m: float
    weight_kg: float
    posture: str
    behaviour: str
    receiver: dict[str, float]
    hand_reach_duration_s: float
    pull_angle_deg: float
    object_mass_kg: float
    mu_static: float
    mu_kinetic: float
    ft_noise_std_n: float
    ft_bias_std_n: float
    sim_seed: int

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def draw_episode(run_seed: int, episode: int) -> EpisodeDraw:
    """Episode `episode` (0-based) of the population of `run_seed`: each variable from its own
    stream ``SeedSequence(run_seed, spawn_key=(episode, index))``."""
    drawn: dict[str, Any] = {}
    for index, variable in enumerate(VARIABLES):
        rng = np.random.default_rng(np.random.SeedSequence(run_seed, spawn_key=(episode, index)))
        drawn[variable.name] = variable.draw(rng, drawn)
    return EpisodeDraw(episode=episode, **drawn)
