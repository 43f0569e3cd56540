"""Randomised handover episodes for the Monte-Carlo controller benchmark.

One chunk of episodes is one vectorised run of the realistic contact plant
(`robot_sim.contact`). Within a chunk every episode has its own object mass, friction,
pull angle, receiver behaviour and timing; the sensor noise levels are drawn per chunk
(the plant's sensor model takes one noise level per run).

Distributions (gripper frame, x toward the receiver, y down; φ > 0 pulls downward):
- pull angle φ ~ U(−45°, 45°) (bumps come from the receiver's side: direction π + φ);
- μ_s ~ U(0.2, 0.9), μ_k = μ_s × U(0.7, 0.95) (both pads together);
- mass ~ U(0.05, 0.6) kg;
- behaviour: taking 40 %, dropping 20 %, hesitating 20 %, bumping 20 % (weights settable);
- timing: reach starts U(0.1, 0.3) s, lasts U(0.6, 1.0) s over U(0.2, 0.35) m; load transfer
  U(0.3, 0.7) s (taking; thesis §3.2); pull after U(0, 0.2) s, over U(0.5, 1.2) s and
  U(0.1, 0.3) m; grasp strength U(10, 30) N; weight feed-forward U(0.8, 1.0) (taking);
  weight estimate ±10 %; dropping lets go U(0.8, 1.6) s after its grasp; hesitating grasps
  to U(0.4, 0.9) and lets go U(0.2, 0.6) s after; bumps start at U(0.5, 1.5) s, 2–4 cm deep
  over U(0.08, 0.2) s;
- sensor noise per chunk: F/T white noise σ ~ U(0.01, 0.15) N, F/T bias σ 0.05 N, noise
  on a_y σ ~ U(0, 1.5) m/s².

`EpisodeObjectParams` lets one vectorised run carry a different mass and friction per
episode: the plant's equations are element-wise, so arrays of shape (n,) in the object
parameters work as they do in the receiver parameters (the tests check a mixed-mass batch
against runs with one scalar mass each, bit for bit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from robot_sim.contact.config import GRAVITY_M_S2, ObjectParams, SensorParams, SimConfig
from robot_sim.contact.receiver import (
    Behaviour,
    ReceiverParams,
    bumping,
    dropping,
    hesitating,
    stack_receivers,
    taking,
)
from services.gripper.errors import GripperError

__all__ = ["BEHAVIOUR_NAMES", "ChunkSpec", "EpisodeDistribution", "EpisodeObjectParams", "sample_chunk"]

BEHAVIOUR_NAMES = {int(Behaviour.TAKING): "taking", int(Behaviour.DROPPING): "dropping",
                   int(Behaviour.BUMPING): "bumping", int(Behaviour.HESITATING): "hesitating"}


@dataclass(frozen=True)
class EpisodeObjectParams(ObjectParams):
    """`ObjectParams` whose mass and friction are arrays of shape (n,), one per episode."""

    def __post_init__(self) -> None:
        m = np.asarray(self.mass_kg, dtype=float)
        mus = np.asarray(self.mu_static, dtype=float)
        muk = np.asarray(self.mu_kinetic, dtype=float)
        if m.ndim != 1 or mus.shape != m.shape or muk.shape != m.shape:
            raise GripperError("per-episode object parameters need mass, μ_s and μ_k arrays of one shape (n,)")
        if not (np.all(np.isfinite(m)) and np.all(m > 0)):
            raise GripperError("object masses must be finite and > 0 kg")
        if not (np.all(muk > 0) and np.all(muk <= mus) and np.all(np.isfinite(mus))):
            raise GripperError("need 0 < μ_k ≤ μ_s for every episode")

    @property
    def weight_n(self):  # noqa: D401 - same meaning as the parent's
        """W = M g per episode (N), shape (n,)."""
        return np.asarray(self.mass_kg, dtype=float) * GRAVITY_M_S2


def _range(lo: float, hi: float) -> tuple[float, float]:
    return (float(lo), float(hi))


@dataclass(frozen=True)
class EpisodeDistribution:
    """Ranges the benchmark samples from (uniform unless said otherwise); see the module
    docstring. Angles in degrees, masses in kg, forces in N, accelerations in m/s²."""

    pull_angle_deg: tuple[float, float] = (-45.0, 45.0)
    mu_static: tuple[float, float] = (0.2, 0.9)
    mu_kinetic_ratio: tuple[float, float] = (0.7, 0.95)
    mass_kg: tuple[float, float] = (0.05, 0.6)
    behaviour_weights: dict[str, float] = field(
        default_factory=lambda: {"taking": 0.4, "dropping": 0.2, "hesitating": 0.2, "bumping": 0.2})
    ft_noise_std_n: tuple[float, float] = (0.01, 0.15)
    ft_bias_std_n: float = 0.05
    accel_noise_std_m_s2: tuple[float, float] = (0.0, 1.5)

    def __post_init__(self) -> None:
        for name in ("pull_angle_deg", "mu_static", "mu_kinetic_ratio", "mass_kg", "ft_noise_std_n",
                     "accel_noise_std_m_s2"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise GripperError(f"episode distribution {name} must be a finite range lo <= hi, got {(lo, hi)}")
        if self.mass_kg[0] <= 0 or self.mu_static[0] <= 0:
            raise GripperError("masses and friction coefficients must be > 0")
        if not (0 < self.mu_kinetic_ratio[0] and self.mu_kinetic_ratio[1] <= 1):
            raise GripperError("mu_kinetic_ratio must lie in (0, 1]")
        unknown = set(self.behaviour_weights) - set(BEHAVIOUR_NAMES.values())
        if unknown or not self.behaviour_weights:
            raise GripperError(f"behaviour_weights: unknown behaviours {sorted(unknown)}; "
                               f"use {sorted(BEHAVIOUR_NAMES.values())}")
        w = np.array(list(self.behaviour_weights.values()), dtype=float)
        if np.any(w < 0) or not w.sum() > 0:
            raise GripperError("behaviour_weights must be >= 0 and not all zero")


@dataclass(frozen=True)
class ChunkSpec:
    """One sampled chunk: its plant config, receivers and per-episode draws."""

    config: SimConfig
    receivers: ReceiverParams
    mass_kg: np.ndarray
    mu_static: np.ndarray
    pull_angle_rad: np.ndarray
    behaviour: np.ndarray
    grasp_start_s: np.ndarray


def _one_receiver(kind: str, phi: float, weight_n: float, rng: np.random.Generator) -> ReceiverParams:
    w_est = weight_n * rng.uniform(0.9, 1.1)
    common = dict(pull_angle_rad=phi, weight_n=w_est, reach_start_s=rng.uniform(0.1, 0.3),
                  reach_duration_s=rng.uniform(0.6, 1.0), reach_distance_m=rng.uniform(0.2, 0.35))
    if kind == "taking":
        return taking(**common, transfer_s=rng.uniform(0.3, 0.7), pull_delay_s=rng.uniform(0.0, 0.2),
                      pull_duration_s=rng.uniform(0.5, 1.2), pull_distance_m=rng.uniform(0.1, 0.3),
                      grasp_strength_n=rng.uniform(10.0, 30.0), weight_feedforward=rng.uniform(0.8, 1.0))
    if kind == "dropping":
        return dropping(**common, transfer_s=rng.uniform(0.2, 0.5), pull_delay_s=rng.uniform(0.0, 0.2),
                        pull_duration_s=rng.uniform(0.5, 1.2), pull_distance_m=rng.uniform(0.1, 0.3),
                        letgo_after_s=rng.uniform(0.8, 1.6), grasp_strength_n=rng.uniform(10.0, 30.0))
    if kind == "hesitating":
        return hesitating(**common, grasp_build_s=rng.uniform(0.2, 0.4), grasp_level=rng.uniform(0.4, 0.9),
                          pull_distance_m=rng.uniform(0.0, 0.02), letgo_after_s=rng.uniform(0.2, 0.6),
                          grasp_strength_n=rng.uniform(10.0, 30.0))
    return bumping(pull_angle_rad=math.pi + phi, weight_n=w_est, bump_start_s=rng.uniform(0.5, 1.5),
                   penetration_m=rng.uniform(0.02, 0.04), sweep_duration_s=rng.uniform(0.08, 0.2))


def sample_chunk(dist: EpisodeDistribution, n: int, rng: np.random.Generator,
                 base: SimConfig | None = None) -> ChunkSpec:
    """Draw `n` episodes (one vectorised chunk) from `dist` with `rng`."""
    if n < 1:
        raise GripperError(f"a chunk needs at least one episode, got {n}")
    base = base or SimConfig()
    kinds = list(dist.behaviour_weights)
    p = np.array([dist.behaviour_weights[k] for k in kinds], dtype=float)
    p /= p.sum()
    mass = rng.uniform(*dist.mass_kg, n)
    mu_s = rng.uniform(*dist.mu_static, n)
    mu_k = mu_s * rng.uniform(*dist.mu_kinetic_ratio, n)
    phi = np.radians(rng.uniform(*dist.pull_angle_deg, n))
    chosen = rng.choice(len(kinds), size=n, p=p)
    receivers = [_one_receiver(kinds[c], float(phi[i]), float(mass[i] * GRAVITY_M_S2), rng)
                 for i, c in enumerate(chosen)]
    stacked = stack_receivers(receivers)
    sensors = replace(base.sensors, ft_noise_std_n=float(rng.uniform(*dist.ft_noise_std_n)),
                      ft_bias_std_n=dist.ft_bias_std_n,
                      accel_noise_std_m_s2=float(rng.uniform(*dist.accel_noise_std_m_s2)))
    obj = EpisodeObjectParams(mass_kg=mass, mu_static=mu_s, mu_kinetic=mu_k,
                              pad_extent_x_m=base.obj.pad_extent_x_m, pad_extent_y_m=base.obj.pad_extent_y_m,
                              optical_face_x_m=base.obj.optical_face_x_m, optical_face_y_m=base.obj.optical_face_y_m)
    config = replace(base, obj=obj, sensors=_checked_sensors(sensors))
    return ChunkSpec(config=config, receivers=stacked, mass_kg=mass, mu_static=mu_s, pull_angle_rad=phi,
                     behaviour=np.asarray(stacked.behaviour, dtype=np.int64),
                     grasp_start_s=np.asarray(stacked.grasp_start_s, dtype=float))


def _checked_sensors(sensors: SensorParams) -> SensorParams:
    return SensorParams(**{k: getattr(sensors, k) for k in SensorParams.__dataclass_fields__})
