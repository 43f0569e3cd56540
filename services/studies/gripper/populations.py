"""The benchmark's named episode distributions, their declared sub-populations, and the
plan of a run's chunks.

A sub-population is one receiver kind (behaviour × when a taking receiver lifts: with its
grasp, after its pull, or never) under one gripper class (force rate × loop rate). Every
figure of the benchmark is reported per sub-population as well as overall
(`services.studies.gripper.benchmark.subpopulation_stats`), so that a gain in one cannot
hide a loss in another.

Named distributions (`POPULATIONS`):
- "narrow": the first benchmark's (`EpisodeDistribution()`): taking 40 %, dropping,
  hesitating and bumping 20 % each, every taking receiver lifting with its grasp, every
  gripper the slow one (50 N/s, 25 Hz). A seed gives the episodes and numbers it gave
  before the distribution was widened: `--population narrow` reproduces the old figures.
- "wide" (the default): six receiver kinds (taking, pull-first, drag, dropping,
  hesitating, bumping) × four gripper classes (the 2 × 2 of 50 or 500 N/s and 25 or 250 Hz),
  each of the 24 sub-populations the same share, drawn *stratified*: a run of n episodes has
  exactly n/24 of each (largest remainder when n is not a multiple of 24), so the overall
  figures are the plain mean over the sub-populations.
- "arms": the six receiver kinds of "wide" × the grippers of the described arms
  (`handover_model.robots`: the default arm's, the Franka Hand, a Robotiq 2F-85-like gripper on the
  UR5, the SO-ARM101's jaw), each with its force rate, loop rate and force range
  (`episodes.arm_gripper_class`), stratified as "wide".

Seeds: chunk i of a run gets child i of `SeedSequence(seed)` (as the first benchmark did);
a stratified run deals the receiver kinds of each gripper class with the next child.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from services.gripper.errors import GripperError
from services.studies.gripper.episodes import (
    ARM_GRIPPERS,
    GRIPPER_CLASSES,
    GRIPPER_CODES,
    RECEIVER_KINDS,
    ChunkSpec,
    EpisodeDistribution,
    sample_chunk,
)

__all__ = ["ChunkPlan", "DEFAULT_POPULATION", "POPULATIONS", "RECEIVER_LABELS", "SubPopulation", "allocate",
           "chunk_seeds", "draw_planned_chunk", "plan_chunks", "population", "subpopulations"]

#: How the tables name the receiver kinds.
RECEIVER_LABELS = {"taking": "taking, lift first", "pull-first": "taking, pull first",
                   "drag": "taking, drag (never lifts)", "dropping": "dropping", "hesitating": "hesitating",
                   "bumping": "bumping"}

POPULATIONS = {
    "narrow": EpisodeDistribution(),
    "wide": EpisodeDistribution(
        behaviour_weights={k: 1.0 for k in ("taking", "pull-first", "drag", "dropping", "hesitating", "bumping")},
        gripper_weights={g: 1.0 for g in ("slow", "fast-loop", "fast-force", "fast")}, stratified=True),
    "arms": EpisodeDistribution(
        behaviour_weights={k: 1.0 for k in ("taking", "pull-first", "drag", "dropping", "hesitating", "bumping")},
        gripper_weights={g: 1.0 for g in ARM_GRIPPERS}, stratified=True),
}
DEFAULT_POPULATION = "wide"


def population(name: str, grippers: list[str] | None = None) -> EpisodeDistribution:
    """The named distribution, optionally with other gripper classes (equal shares)."""
    if name not in POPULATIONS:
        raise GripperError(f"unknown population {name!r}; use one of {list(POPULATIONS)}")
    dist = POPULATIONS[name]
    if grippers:
        dist = replace(dist, gripper_weights={g: 1.0 for g in grippers})
    return dist


@dataclass(frozen=True)
class SubPopulation:
    """One receiver kind under one gripper class."""

    kind: str
    gripper: str

    @property
    def kind_code(self) -> int:
        """Index of the kind in `RECEIVER_KINDS`."""
        return RECEIVER_KINDS.index(self.kind)

    @property
    def gripper_code(self) -> int:
        """Index of the gripper class in `GRIPPER_CLASSES`."""
        return GRIPPER_CODES[self.gripper]

    @property
    def receiver_label(self) -> str:
        return RECEIVER_LABELS[self.kind]

    @property
    def gripper_label(self) -> str:
        return GRIPPER_CLASSES[self.gripper].label

    def mask(self, kind: np.ndarray, gripper: np.ndarray) -> np.ndarray:
        """Which episodes (per-episode kind and gripper codes) belong to it."""
        return (np.asarray(kind) == self.kind_code) & (np.asarray(gripper) == self.gripper_code)


def _weighted(weights: dict[str, float], order) -> list[tuple[str, float]]:
    return [(k, float(weights[k])) for k in order if weights.get(k, 0.0) > 0.0]


def subpopulations(dist: EpisodeDistribution) -> list[SubPopulation]:
    """The declared sub-populations of `dist` (kinds with a weight > 0 × gripper classes
    with a weight > 0), kind by kind, in the order of the distribution's weights."""
    return [SubPopulation(k, g) for k, _ in _weighted(dist.behaviour_weights, dist.behaviour_weights)
            for g, _ in _weighted(dist.gripper_weights, dist.gripper_weights)]


def allocate(n: int, weights: list[float]) -> np.ndarray:
    """n split in proportion to `weights` by the largest remainder (ties: first first)."""
    w = np.asarray(weights, dtype=float)
    share = n * w / w.sum()
    counts = np.floor(share).astype(np.int64)
    order = np.argsort(-(share - counts), kind="stable")
    counts[order[: n - int(counts.sum())]] += 1
    return counts


@dataclass(frozen=True)
class ChunkPlan:
    """One chunk of a run: its index, size, seed, gripper class and (stratified runs) the
    receiver kind of each of its episodes."""

    index: int
    size: int
    seed: np.random.SeedSequence
    gripper: str
    kinds: tuple[str, ...] | None = None


def plan_chunks(dist: EpisodeDistribution, n_episodes: int, chunk_size: int, seed: int) -> list[ChunkPlan]:
    """The chunks of a run of `n_episodes` (the same for every controller): the gripper
    classes get their exact shares (largest remainder), each cut into chunks of at most
    `chunk_size`; a stratified distribution also deals its receiver kinds exactly, in a
    random order."""
    if n_episodes < 1 or chunk_size < 1:
        raise GripperError(f"need n_episodes >= 1 and chunk_size >= 1, got {n_episodes}, {chunk_size}")
    grippers = _weighted(dist.gripper_weights, GRIPPER_CLASSES)
    per_gripper = allocate(n_episodes, [w for _, w in grippers])
    cuts = [(g, min(chunk_size, int(m) - i)) for (g, _), m in zip(grippers, per_gripper)
            for i in range(0, int(m), chunk_size)]
    root = np.random.SeedSequence(seed)
    seqs = root.spawn(len(cuts))
    kinds: list[tuple[str, ...] | None] = [None] * len(cuts)
    if dist.stratified:
        rng = np.random.default_rng(root.spawn(1)[0])
        names = _weighted(dist.behaviour_weights, RECEIVER_KINDS)
        for (g, _), m in zip(grippers, per_gripper):
            dealt = rng.permutation(np.repeat([k for k, _ in names], allocate(int(m), [w for _, w in names])))
            at = 0
            for i, (cg, size) in enumerate(cuts):
                if cg == g:
                    kinds[i] = tuple(str(k) for k in dealt[at:at + size])
                    at += size
    return [ChunkPlan(i, size, seqs[i], g, kinds[i]) for i, (g, size) in enumerate(cuts)]


def chunk_seeds(plan: ChunkPlan) -> tuple[np.random.SeedSequence, np.random.SeedSequence]:
    """(draw, noise) seeds of a planned chunk: children of a fresh copy of the plan's seed
    (`spawn` counts its children, and the same chunk serves every controller)."""
    seq = plan.seed
    draw_seq, noise_seq = np.random.SeedSequence(seq.entropy, spawn_key=seq.spawn_key).spawn(2)
    return draw_seq, noise_seq


def draw_planned_chunk(dist: EpisodeDistribution, plan: ChunkPlan) -> tuple[ChunkSpec, np.random.SeedSequence]:
    """One planned chunk's episodes and its sensor-noise seed, as every study draws them (the
    benchmark, the oracle, tuning, sweeps, the MuJoCo closed loop)."""
    draw_seq, noise_seq = chunk_seeds(plan)
    chunk = sample_chunk(dist, plan.size, np.random.default_rng(draw_seq), gripper=plan.gripper, kinds=plan.kinds)
    return chunk, noise_seq
