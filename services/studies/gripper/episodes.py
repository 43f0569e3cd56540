"""Randomised handover episodes for the Monte-Carlo controller benchmark.

One chunk of episodes is one vectorised run of the realistic contact plant
(`robot_sim.contact`). Within a chunk every episode has its own object mass, friction,
pull angle, receiver kind and timing; the sensor noise levels are drawn per chunk (the
plant's sensor model takes one noise level per run), and so is the gripper class (one
actuator and one controller period per run). The named distributions ("narrow", the first
benchmark's, and "wide") and their sub-populations: `services.studies.gripper.populations`.

Distributions (gripper frame, x toward the receiver, y down; φ > 0 pulls downward):
- pull angle φ ~ U(−45°, 45°) (bumps come from the receiver's side: direction π + φ);
- μ_s ~ U(0.2, 0.9), μ_k = μ_s × U(0.7, 0.95) (both pads together);
- mass ~ U(0.05, 0.6) kg;
- receiver kind (`RECEIVER_KINDS`): taking 40 %, dropping 20 %, hesitating 20 %, bumping
  20 % (weights settable; "pull-first" and "drag" are taking receivers who pull first and
  take up the weight 0.3–0.8 s after their pull starts, over 0.3–0.7 s, or never: weight 0
  by default, in the "wide" population);
- gripper class (`GRIPPER_CLASSES`): "slow" (50 N/s, 25 Hz, the thesis's robot) by
  default; "fast-loop" (50 N/s, 250 Hz), "fast-force" (500 N/s, 25 Hz), "fast" (500 N/s,
  250 Hz) and "medium" (150 N/s, 100 Hz) settable. The controllers step at the class's
  control period (100 Hz, or the loop's rate above 100 Hz, with the F/T read as often);
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
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from handover_model import robots
from handover_model.robots import RobotDescription
from robot_sim.contact.config import GRAVITY_M_S2, ContactSimError, ObjectParams, SensorParams, SimConfig
from robot_sim.contact.receiver import Behaviour, ReceiverParams, stack_receivers
from robot_sim.contact.sampling import sample_one
from services.gripper.errors import GripperError

__all__ = ["ARM_GRIPPERS", "BEHAVIOUR_NAMES", "ChunkSpec", "EpisodeDistribution", "EpisodeObjectParams",
           "GRIPPER_CLASSES", "GRIPPER_CODES", "GripperClass", "RECEIVER_KINDS", "sample_chunk"]

BEHAVIOUR_NAMES = {int(Behaviour.TAKING): "taking", int(Behaviour.DROPPING): "dropping",
                   int(Behaviour.BUMPING): "bumping", int(Behaviour.HESITATING): "hesitating"}
#: Receiver kinds, in code order (the code of the first four is their `Behaviour`): the
#: taking receiver who lifts with the grasp ("taking"), and the two who pull first.
RECEIVER_KINDS = ("taking", "dropping", "bumping", "hesitating", "pull-first", "drag")


@dataclass(frozen=True)
class GripperClass:
    """A gripper actuator of the benchmark: its force rate (N/s, the finger speed limit
    through the spring) and position-loop rate (Hz). The loop period must be a whole number
    of plant steps; the controllers step at `SimConfig.control_period_s` of the setup
    (`setup`): 100 Hz with a loop up to 100 Hz, the loop's rate above. An arm's gripper
    (`arm_gripper_class`) also has its force range (N): the plant holds it to it."""

    name: str
    force_rate_n_per_s: float
    loop_rate_hz: float
    max_force_n: float = 140.0
    min_force_n: float = 0.0

    def setup(self, base: SimConfig) -> SimConfig:
        """`base` with this gripper (`SimConfig.with_gripper_rates`, `SimConfig.with_gripper`)."""
        try:
            if self.max_force_n == 140.0 and self.min_force_n == 0.0:
                return base.with_gripper_rates(self.force_rate_n_per_s, self.loop_rate_hz)
            return base.with_gripper(self.force_rate_n_per_s, self.loop_rate_hz, self.max_force_n, self.min_force_n)
        except ContactSimError as exc:
            raise GripperError(f"gripper class {self.name!r}: {exc}") from None

    @property
    def label(self) -> str:
        """Name with its numbers, e.g. "fast (500 N/s, 250 Hz)", "ur5 (75 N/s, 50 Hz, 20–140 N)"."""
        limits = "" if self.max_force_n == 140.0 and self.min_force_n == 0.0 else \
            f", {self.min_force_n:g}–{self.max_force_n:g} N"
        return f"{self.name} ({self.force_rate_n_per_s:g} N/s, {self.loop_rate_hz:g} Hz{limits})"


def arm_gripper_class(desc: RobotDescription) -> GripperClass:
    """The gripper of a described arm as a benchmark class, named after the arm (its force
    capped at the plant's 140 N hand limit)."""
    g = desc.gripper
    return GripperClass(desc.name, g.force_rate_n_s, g.loop_rate_hz, min(g.force_max_n, 140.0), g.force_min_n)


#: The gripper classes, in code order. "slow" is the thesis's robot's gripper (the plant's
#: default actuator): its setup is the default config, bit for bit.
GRIPPER_CLASSES = {c.name: c for c in (
    GripperClass("slow", 50.0, 25.0), GripperClass("fast-loop", 50.0, 250.0), GripperClass("fast-force", 500.0, 25.0),
    GripperClass("fast", 500.0, 250.0), GripperClass("medium", 150.0, 100.0),
    *(arm_gripper_class(d) for d in robots.BUILTIN.values()))}
#: The grippers of the described arms (`handover_model.robots`), by arm name.
ARM_GRIPPERS = tuple(robots.BUILTIN)
#: Gripper class name → its code (index in `GRIPPER_CLASSES`).
GRIPPER_CODES = {name: i for i, name in enumerate(GRIPPER_CLASSES)}


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
    gripper_weights: dict[str, float] = field(default_factory=lambda: {"slow": 1.0})
    stratified: bool = False
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
        for name, known in (("behaviour_weights", RECEIVER_KINDS), ("gripper_weights", tuple(GRIPPER_CLASSES))):
            weights = getattr(self, name)
            unknown = set(weights) - set(known)
            if unknown or not weights:
                raise GripperError(f"{name}: unknown names {sorted(unknown)}; use {list(known)}")
            w = np.array(list(weights.values()), dtype=float)
            if np.any(w < 0) or not w.sum() > 0 or not np.all(np.isfinite(w)):
                raise GripperError(f"{name} must be finite, >= 0 and not all zero")


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
    kind: np.ndarray | None = None
    gripper: str = "slow"

    @property
    def control_period_s(self) -> float:
        """Period the controllers step at in this chunk, s."""
        return self.config.control_period_s


def _chunk_gripper(dist: EpisodeDistribution, gripper: str | None) -> GripperClass:
    if gripper is None:
        if len(dist.gripper_weights) != 1:
            raise GripperError(f"a chunk has one gripper class: name one of {list(dist.gripper_weights)}")
        gripper = next(iter(dist.gripper_weights))
    if gripper not in GRIPPER_CLASSES:
        raise GripperError(f"unknown gripper class {gripper!r}; use {list(GRIPPER_CLASSES)}")
    return GRIPPER_CLASSES[gripper]


def sample_chunk(dist: EpisodeDistribution, n: int, rng: np.random.Generator,
                 base: SimConfig | None = None, gripper: str | None = None,
                 kinds: Sequence[str] | None = None) -> ChunkSpec:
    """Draw `n` episodes (one vectorised chunk) from `dist` with `rng`, with the gripper
    class `gripper` (default: the distribution's only one) and the receiver kinds `kinds`
    (one per episode; default: drawn with the distribution's weights)."""
    if n < 1:
        raise GripperError(f"a chunk needs at least one episode, got {n}")
    base = base or SimConfig()
    grip = _chunk_gripper(dist, gripper)
    names = list(dist.behaviour_weights)
    p = np.array([dist.behaviour_weights[k] for k in names], dtype=float)
    p /= p.sum()
    mass = rng.uniform(*dist.mass_kg, n)
    mu_s = rng.uniform(*dist.mu_static, n)
    mu_k = mu_s * rng.uniform(*dist.mu_kinetic_ratio, n)
    phi = np.radians(rng.uniform(*dist.pull_angle_deg, n))
    if kinds is None:
        chosen = [names[c] for c in rng.choice(len(names), size=n, p=p)]
    else:
        chosen = list(kinds)
        if len(chosen) != n or not set(chosen) <= set(RECEIVER_KINDS):
            raise GripperError(f"need {n} receiver kinds out of {list(RECEIVER_KINDS)}, got {len(chosen)}")
    receivers = [sample_one(k, rng, float(mass[i] * GRAVITY_M_S2), float(phi[i]), math.pi + float(phi[i]))
                 for i, k in enumerate(chosen)]
    stacked = stack_receivers(receivers)
    sensors = replace(base.sensors, ft_noise_std_n=float(rng.uniform(*dist.ft_noise_std_n)),
                      ft_bias_std_n=dist.ft_bias_std_n,
                      accel_noise_std_m_s2=float(rng.uniform(*dist.accel_noise_std_m_s2)))
    obj = EpisodeObjectParams(mass_kg=mass, mu_static=mu_s, mu_kinetic=mu_k,
                              pad_extent_x_m=base.obj.pad_extent_x_m, pad_extent_y_m=base.obj.pad_extent_y_m,
                              optical_face_x_m=base.obj.optical_face_x_m, optical_face_y_m=base.obj.optical_face_y_m)
    config = grip.setup(replace(base, obj=obj, sensors=_checked_sensors(sensors)))
    return ChunkSpec(config=config, receivers=stacked, mass_kg=mass, mu_static=mu_s, pull_angle_rad=phi,
                     behaviour=np.asarray(stacked.behaviour, dtype=np.int64),
                     grasp_start_s=np.asarray(stacked.grasp_start_s, dtype=float),
                     kind=np.array([RECEIVER_KINDS.index(k) for k in chosen], dtype=np.int64), gripper=grip.name)


def _checked_sensors(sensors: SensorParams) -> SensorParams:
    return SensorParams(**{k: getattr(sensors, k) for k in SensorParams.__dataclass_fields__})
