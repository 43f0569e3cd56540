"""The release controllers closed-loop on both plants: the benchmark's episodes, each run on
our contact plant and on MuJoCo with the same friction, receiver, gripper, sensors and noise.

Episodes: exactly the benchmark's (`benchmark._run_job`): `populations.plan_chunks(dist, n,
chunk_size, seed)` cuts the run into chunks, chunk i is drawn by `episodes.sample_chunk` from
the first child of `SeedSequence(seed).spawn(...)[i]`, so episode i here is episode i of
`handover-study bench --population P --seed S -n N --chunk-size C`. Two things differ, and only
so that the comparison isolates the contact physics:
- **friction**: MuJoCo has one coefficient, so BOTH plants use μ_k = μ_s = the episode's μ_s
  (the benchmark draws μ_k = μ_s × U(0.7, 0.95) for our plant);
- **one episode at a time** (`robot_sim.contact.episode.run_episode` on ours,
  `robot_sim.contact.crosscheck.closed_loop.run_mujoco_episode` on MuJoCo), each with its own
  noise seed, child j of the chunk's noise seed (`episode_seed`): both plants draw the same
  F/T bias and noise and a_y noise. The benchmark's vectorised chunk draws its noise for the
  whole chunk at once, so its verdicts are not these, bit for bit.

The work is cut into tasks of (controller, chunk, a slice of its episodes) for the studies'
engine (`services.studies.engine.run_tasks`). Frames and units as in `robot_sim.contact`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from robot_sim.contact.config import ObjectParams, SimConfig
from robot_sim.contact.crosscheck.closed_loop import holds_at_release, run_mujoco_episode
from robot_sim.contact.crosscheck.mjcf import MujocoParams
from robot_sim.contact.episode import EpisodeResult, run_episode
from robot_sim.contact.outcome import BatchOutcome
from robot_sim.contact.receiver import ReceiverParams
from services.gripper.controllers.registry import CONTROLLER_NAMES, make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.episodes import ChunkSpec, EpisodeDistribution
from services.studies.gripper.populations import ChunkPlan, chunk_seeds, draw_planned_chunk, plan_chunks

__all__ = ["EpisodeSpec", "LoopResult", "LoopTask", "episode_seed", "episode_spec", "plan_tasks", "run_task",
           "assemble", "PLANTS"]

PLANTS = ("ours", "mujoco")


@dataclass(frozen=True)
class EpisodeSpec:
    """One episode, ready to run on either plant: its setup (the object with μ_k = μ_s), its
    receiver, its noise seed, and what it was drawn as (index in the run, receiver kind)."""

    index: int
    config: SimConfig
    receiver: ReceiverParams
    seed: np.random.SeedSequence
    kind: int
    behaviour: int
    grasp_start_s: float


def _chunk(plan: ChunkPlan, dist: EpisodeDistribution) -> ChunkSpec:
    return draw_planned_chunk(dist, plan)[0]


def episode_seed(plan: ChunkPlan, position: int) -> np.random.SeedSequence:
    """Noise seed of the episode at `position` in the chunk: child `position` of the chunk's
    noise seed (the same for both plants and every controller)."""
    _, noise = chunk_seeds(plan)
    return np.random.SeedSequence(noise.entropy, spawn_key=tuple(noise.spawn_key) + (int(position),))


def _spec(chunk: ChunkSpec, plan: ChunkPlan, position: int, first_index: int) -> EpisodeSpec:
    base = chunk.config.obj
    mu = float(chunk.mu_static[position])
    obj = ObjectParams(mass_kg=float(chunk.mass_kg[position]), mu_static=mu, mu_kinetic=mu,
                       pad_extent_x_m=base.pad_extent_x_m, pad_extent_y_m=base.pad_extent_y_m,
                       optical_face_x_m=base.optical_face_x_m, optical_face_y_m=base.optical_face_y_m)
    kind = -1 if chunk.kind is None else int(chunk.kind[position])
    return EpisodeSpec(index=first_index + position, config=replace(chunk.config, obj=obj),
                       receiver=chunk.receivers.episode(position), seed=episode_seed(plan, position), kind=kind,
                       behaviour=int(chunk.behaviour[position]), grasp_start_s=float(chunk.grasp_start_s[position]))


def episode_spec(dist: EpisodeDistribution, n_episodes: int, chunk_size: int, seed: int, index: int) -> EpisodeSpec:
    """Episode `index` (0-based) of a run of `n_episodes` (to replay one)."""
    if not 0 <= index < n_episodes:
        raise GripperError(f"episode index {index} is outside the run's 0..{n_episodes - 1}")
    first = 0
    for plan in plan_chunks(dist, n_episodes, chunk_size, seed):
        if index < first + plan.size:
            return _spec(_chunk(plan, dist), plan, index - first, first)
        first += plan.size
    raise GripperError(f"episode index {index} not found")  # unreachable: the chunks cover the run


@dataclass(frozen=True)
class LoopTask:
    """Episodes [start, stop) of chunk `plan` under controller `controller` (picklable)."""

    controller: str
    plan: ChunkPlan
    first_index: int
    start: int
    stop: int
    dist: EpisodeDistribution
    params: MujocoParams = MujocoParams()


def plan_tasks(controllers: list[str], dist: EpisodeDistribution, n_episodes: int, seed: int, chunk_size: int = 250,
               task_size: int = 25, params: MujocoParams = MujocoParams()) -> list[LoopTask]:
    """The tasks of a run, controller by controller, chunk by chunk (validated names and sizes)."""
    unknown = [c for c in controllers if c not in CONTROLLER_NAMES]
    if unknown or not controllers:
        raise GripperError(f"unknown controller(s) {unknown}; choose from: {', '.join(CONTROLLER_NAMES)}")
    if len(set(controllers)) != len(controllers):
        raise GripperError(f"a controller is named twice in {controllers}")
    if task_size < 1:
        raise GripperError(f"task size must be >= 1, got {task_size}")
    plans = plan_chunks(dist, n_episodes, chunk_size, seed)
    firsts = np.concatenate(([0], np.cumsum([p.size for p in plans])[:-1])).astype(int)
    return [LoopTask(c, plan, int(first), a, min(a + task_size, plan.size), dist, params)
            for c in controllers for plan, first in zip(plans, firsts) for a in range(0, plan.size, task_size)]


def _row(result: EpisodeResult) -> tuple:
    o = result.outcome
    return (o.released, o.release_time_s, o.dropped, o.drop_time_s, o.handed_over, o.force_overshoot_n,
            o.slip_distance_m, o.peak_down_accel_m_s2, o.mode_switch_count, int(result.trace.mode[-1]),
            holds_at_release(result.trace))


def run_task(task: LoopTask) -> dict:
    """Run a task's episodes on both plants. Returns per plant the outcome rows (fields of
    `BatchOutcome` plus holds-at-release) and the wall time (s), and the episodes' draws."""
    chunk = _chunk(task.plan, task.dist)
    rows: dict[str, list] = {p: [] for p in PLANTS}
    wall = dict.fromkeys(PLANTS, 0.0)
    draws = []
    for j in range(task.start, task.stop):
        spec = _spec(chunk, task.plan, j, task.first_index)
        for plant in PLANTS:
            controller = make_controller(task.controller, period_s=spec.config.control_period_s)
            t0 = time.perf_counter()
            if plant == "ours":
                result = run_episode(spec.config, spec.receiver, controller, seed=spec.seed)
            else:
                result = run_mujoco_episode(spec.config, spec.receiver, controller, seed=spec.seed,
                                            params=task.params)
            wall[plant] += time.perf_counter() - t0
            rows[plant].append(_row(result))
        draws.append((spec.index, spec.kind, spec.behaviour, spec.grasp_start_s, spec.config.obj.mass_kg,
                      spec.config.obj.mu_static, float(chunk.pull_angle_rad[j])))
    return {"controller": task.controller, "rows": rows, "wall_s": wall, "draws": draws}


_FIELDS = ("released", "release_time_s", "dropped", "drop_time_s", "handed_over", "force_overshoot_n",
           "slip_distance_m", "peak_down_accel_m_s2", "mode_switch_count", "final_mode")
_DRAWS = ("index", "kind", "behaviour", "grasp_start_s", "mass_kg", "mu", "pull_angle_rad")


@dataclass
class LoopResult:
    """Both plants' outcomes per controller over the same episodes (in episode order), the
    episodes' draws (arrays of shape (n,)) and the wall time per plant (s)."""

    outcomes: dict[str, dict[str, BatchOutcome]]
    holds_at_release: dict[str, dict[str, np.ndarray]]
    draws: dict[str, np.ndarray]
    wall_s: dict[str, float]
    seed: int
    population: str

    @property
    def episodes(self) -> int:
        return int(self.draws["index"].size)

    def episodes_per_s(self, plant: str) -> float:
        """Episodes run per second of wall time on `plant` (all controllers)."""
        runs = self.episodes * len(self.outcomes)
        return runs / self.wall_s[plant] if self.wall_s[plant] > 0 else float("nan")


def _outcome(rows: list[tuple]) -> tuple[BatchOutcome, np.ndarray]:
    cols = list(zip(*rows))
    kinds = {"released": bool, "dropped": bool, "handed_over": bool, "mode_switch_count": np.int64,
             "final_mode": np.int8}
    out = BatchOutcome(**{f: np.asarray(c, dtype=kinds.get(f, float)) for f, c in zip(_FIELDS, cols)})
    return out, np.asarray(cols[-1], dtype=bool)


def assemble(results: list[dict], seed: int, population: str) -> LoopResult:
    """One `LoopResult` from the tasks' results (in `plan_tasks` order)."""
    rows: dict[str, dict[str, list]] = {}
    draws: dict[str, list] = {}
    wall = dict.fromkeys(PLANTS, 0.0)
    for r in results:
        per = rows.setdefault(r["controller"], {p: [] for p in PLANTS})
        for plant in PLANTS:
            per[plant] += r["rows"][plant]
            wall[plant] += r["wall_s"][plant]
        draws.setdefault(r["controller"], []).extend(r["draws"])
    first = next(iter(draws.values()))
    outcomes = {c: {p: _outcome(per[p])[0] for p in PLANTS} for c, per in rows.items()}
    holds = {c: {p: _outcome(per[p])[1] for p in PLANTS} for c, per in rows.items()}
    cols = {name: np.asarray(col) for name, col in zip(_DRAWS, zip(*first))}
    return LoopResult(outcomes=outcomes, holds_at_release=holds, draws=cols, wall_s=wall, seed=seed,
                      population=population)
