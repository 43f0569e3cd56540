"""Seeded random receiver behaviours for batches (`robot_sim.contact.batch`).

Kinds: the four behaviours of the first batches (taking, dropping, bumping, hesitating),
the taking receivers who pull before they lift (pull-first) or never lift (drag), and two
mixtures: "mixed" (one of the first four with equal chance: the draws of a seed are those
the batches have always had) and "mixed-wide" (one of all six with equal chance).

Distributions (assumptions, chosen to span the thesis's cases; gripper frame, φ > 0 pulls
down): φ ~ U(−30°, 30°) (bumping: U(150°, 210°), i.e. toward the robot); reach 0.6–1.0 s
over 0.2–0.35 m; load transfer 0.3–0.7 s (thesis §3.2); pull 0.1–0.3 m over 0.5–1.2 s;
grasp strength 10–30 N; weight estimate ±10 %; dropping lets go 0.8–1.6 s after the grasp;
hesitating grasps to 0.4–0.9 and lets go 0.2–0.6 s after the grasp starts; bumps of 2–4 cm
penetration over 0.08–0.2 s; pull-first receivers take up the weight 0.3–0.8 s after their
pull started, over 0.3–0.7 s (a drag never does).
"""

from __future__ import annotations

import math

import numpy as np

from robot_sim.contact.config import ContactSimError
from robot_sim.contact.receiver import ReceiverParams, bumping, drag, dropping, hesitating, pull_first, taking

__all__ = ["FIRST_KINDS", "KINDS", "MIXTURES", "sample_behaviours", "sample_one"]

#: The behaviours "mixed" draws from, in the order of its draw (do not reorder: seeds).
FIRST_KINDS = ("taking", "dropping", "bumping", "hesitating")
#: Every kind `sample_one` knows ("mixed-wide" draws from these, in this order).
KINDS = FIRST_KINDS + ("pull-first", "drag")
#: Mixtures: name → the kinds drawn with equal chance.
MIXTURES = {"mixed": FIRST_KINDS, "mixed-wide": KINDS}


def _taking_timing(rng: np.random.Generator) -> dict:
    return dict(transfer_s=rng.uniform(0.3, 0.7), pull_delay_s=rng.uniform(0.0, 0.2),
                pull_duration_s=rng.uniform(0.5, 1.2), pull_distance_m=rng.uniform(0.1, 0.3),
                grasp_strength_n=rng.uniform(10.0, 30.0), weight_feedforward=rng.uniform(0.8, 1.0))


def sample_one(kind: str, rng: np.random.Generator, weight_n: float, phi_rad: float,
               bump_phi_rad: float | None = None) -> ReceiverParams:
    """One randomised behaviour of `kind` pulling along `phi_rad` for an object of weight
    `weight_n` (N); a bump comes along `bump_phi_rad`, or along U(150°, 210°) if None. Every
    kind draws the weight estimate and the reach first (a bump does not use the reach), then
    its own numbers, in the order the batches have always drawn them (same seed, same
    episodes)."""
    w_est = weight_n * rng.uniform(0.9, 1.1)
    common = dict(pull_angle_rad=phi_rad, weight_n=w_est, reach_start_s=rng.uniform(0.1, 0.3),
                  reach_duration_s=rng.uniform(0.6, 1.0), reach_distance_m=rng.uniform(0.2, 0.35))
    if kind == "taking":
        return taking(**common, **_taking_timing(rng))
    if kind == "dropping":
        return dropping(**common, transfer_s=rng.uniform(0.2, 0.5), pull_delay_s=rng.uniform(0.0, 0.2),
                        pull_duration_s=rng.uniform(0.5, 1.2), pull_distance_m=rng.uniform(0.1, 0.3),
                        letgo_after_s=rng.uniform(0.8, 1.6), grasp_strength_n=rng.uniform(10.0, 30.0))
    if kind == "hesitating":
        return hesitating(**common, grasp_build_s=rng.uniform(0.2, 0.4), grasp_level=rng.uniform(0.4, 0.9),
                          pull_distance_m=rng.uniform(0.0, 0.02), letgo_after_s=rng.uniform(0.2, 0.6),
                          grasp_strength_n=rng.uniform(10.0, 30.0))
    if kind == "bumping":
        direction = math.radians(rng.uniform(150.0, 210.0)) if bump_phi_rad is None else bump_phi_rad
        return bumping(pull_angle_rad=direction, weight_n=w_est, bump_start_s=rng.uniform(0.5, 1.5),
                       penetration_m=rng.uniform(0.02, 0.04), sweep_duration_s=rng.uniform(0.08, 0.2))
    if kind == "pull-first":
        return pull_first(**common, **_taking_timing(rng), lift_delay_s=rng.uniform(0.3, 0.8),
                          lift_duration_s=rng.uniform(0.3, 0.7))
    if kind == "drag":
        return drag(**common, **_taking_timing(rng))
    raise ContactSimError(f"unknown receiver behaviour {kind!r}; choose one of {list(KINDS) + list(MIXTURES)}")


def sample_behaviours(kind: str, n: int, rng: np.random.Generator,
                      weight_n: float = 0.2 * 9.81) -> list[ReceiverParams]:
    """n randomised behaviours of one kind (see `KINDS`) or of a mixture (`MIXTURES`: each
    of its kinds with equal chance); distributions in the module docstring."""
    if n < 0:
        raise ContactSimError("number of episodes must be >= 0")
    if kind not in KINDS and kind not in MIXTURES:
        raise ContactSimError(f"unknown receiver behaviour {kind!r}; choose one of {list(KINDS) + list(MIXTURES)}")
    mixture = MIXTURES.get(kind)
    out: list[ReceiverParams] = []
    for _ in range(n):
        k = mixture[int(rng.integers(len(mixture)))] if mixture else kind
        out.append(sample_one(k, rng, weight_n, math.radians(rng.uniform(-30.0, 30.0))))
    return out
