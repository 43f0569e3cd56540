"""Monte-Carlo batch runner: vectorised over episodes, seedable, chunked, with progress.

Episodes are cut into chunks of `chunk_size` (`plan_batch`: one `ChunkTask` per chunk); each
chunk is one vectorised run (`run_chunk`: `episode.run_vectorised` on numpy arrays of shape
(chunk,)). Chunk i gets its own seed, spawned from the run's seed
(`numpy.random.SeedSequence(seed).spawn`), which samples its receivers and drives its sensor
noise, so the result depends on (seed, chunk_size) only, never on where or in which order the
chunks run.

`run_batch` runs the chunks one after the other in this process, or hands them to an injected
`map_tasks(function, tasks) -> results` (results in task order): this is how the studies' engine
(`services.studies.engine.run_tasks`, Dask; `handover-contact batch --workers/--address`) runs
them on many cores or machines without robot_sim importing it (robot_sim is a library of the
services, never the other way round).

The controller is built in each chunk by `controller_factory()` (a picklable callable:
a class, or `functools.partial` of one). It steps every `period_s` of plant time
(`episode.run_vectorised`), whatever the gripper's position loop does: the loop latches the
newest command at its own rate (25 Hz by default). A controller slower than
`config.control_period_s` (a gripper loop faster than the controller) gets a warning: the
loop would latch the same command several times.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from tqdm import tqdm

from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.episode import run_vectorised
from handover_model.grip import GripController
from robot_sim.contact.outcome import BatchOutcome
from robot_sim.contact.receiver import ReceiverParams, sample_behaviours, stack_receivers

__all__ = ["BatchResult", "ChunkTask", "MapTasks", "assemble_batch", "chunk_receivers", "plan_batch", "run_batch",
           "run_chunk"]

#: `map_tasks(function, tasks) -> [function(task) for task in tasks]`, run anywhere, results in task order.
MapTasks = Callable[[Callable[[Any], Any], list], list]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchResult:
    """Outcomes of a batch (in episode order), the receivers used, and the wall time (s)."""

    outcome: BatchOutcome
    receivers: ReceiverParams
    wall_time_s: float
    workers: int | None

    @property
    def episodes_per_s(self) -> float:
        """Throughput of this run (episodes per wall-clock second)."""
        return len(self.outcome) / self.wall_time_s if self.wall_time_s > 0 else float("inf")


def chunk_receivers(behaviour: str, n: int, seed_seq: np.random.SeedSequence, weight_n: float) -> ReceiverParams:
    """The stacked receivers of one chunk (reproducible from the chunk's seed)."""
    rng = np.random.default_rng(seed_seq.spawn(1)[0])
    return stack_receivers(sample_behaviours(behaviour, n, rng, weight_n=weight_n))


@dataclass(frozen=True)
class ChunkTask:
    """One chunk of a batch: `size` episodes of `behaviour` drawn from `seed` (picklable)."""

    index: int
    config: SimConfig
    behaviour: str
    size: int
    seed: np.random.SeedSequence
    controller_factory: Callable[[], GripController]


def run_chunk(task: ChunkTask) -> tuple[BatchOutcome, ReceiverParams]:
    """The outcomes and the receivers of one chunk (a pure function of the task)."""
    # A fresh copy: `spawn` counts its children, and the task must give the same chunk wherever
    # and however often it runs (in this process, a worker, a resumed run).
    seed = np.random.SeedSequence(task.seed.entropy, spawn_key=task.seed.spawn_key, pool_size=task.seed.pool_size)
    receivers = chunk_receivers(task.behaviour, task.size, seed, task.config.obj.weight_n)
    noise_seed = seed.spawn(2)[1]
    outcome = run_vectorised(task.config, receivers, task.controller_factory(), seed=noise_seed)
    return outcome, receivers


def plan_batch(config: SimConfig, behaviour: str, n_episodes: int, controller_factory: Callable[[], GripController],
               seed: int = 0, chunk_size: int = 500) -> list[ChunkTask]:
    """The chunks of a batch (validated: episodes, chunk size, behaviour name; warns about a
    controller slower than the gripper loop)."""
    if n_episodes < 1:
        raise ContactSimError(f"n_episodes must be >= 1, got {n_episodes}")
    if chunk_size < 1:
        raise ContactSimError(f"chunk_size must be >= 1, got {chunk_size}")
    sample_behaviours(behaviour, 0, np.random.default_rng(0))  # validates the name before any work
    period_s = float(getattr(controller_factory(), "period_s", 0.01))
    if period_s > config.control_period_s * (1.0 + 1e-9):
        log.warning("the controller steps every %.4g s but the gripper loop latches every %.4g s: "
                    "build it with period_s=config.control_period_s", period_s, 1.0 / config.gripper.loop_rate_hz)
    sizes = [min(chunk_size, n_episodes - i) for i in range(0, n_episodes, chunk_size)]
    seqs = np.random.SeedSequence(seed).spawn(len(sizes))
    return [ChunkTask(i, config, behaviour, s, seqs[i], controller_factory) for i, s in enumerate(sizes)]


def assemble_batch(results: list[tuple[BatchOutcome, ReceiverParams]], wall_time_s: float,
                   workers: int | None) -> BatchResult:
    """One `BatchResult` from the chunks' results (in chunk order)."""
    outcome = BatchOutcome.concatenate([out for out, _rec in results])
    receivers = stack_receivers([rec.episode(j) for _out, rec in results for j in range(rec.n_episodes)])
    return BatchResult(outcome=outcome, receivers=receivers, wall_time_s=wall_time_s, workers=workers)


def run_batch(
    config: SimConfig,
    behaviour: str,
    n_episodes: int,
    controller_factory: Callable[[], GripController],
    seed: int = 0,
    chunk_size: int = 500,
    progress: bool = True,
    map_tasks: MapTasks | None = None,
    workers: int | None = None,
) -> BatchResult:
    """Run `n_episodes` randomised episodes of `behaviour` (a kind of
    `robot_sim.contact.sampling.KINDS`, "mixed" or "mixed-wide") under the controller, and
    judge each from ground truth. The chunks run here, one after the other (with a progress
    bar), or through `map_tasks` (which shows its own progress); `workers` is only reported
    (the processes `map_tasks` runs on; 1 without it)."""
    tasks = plan_batch(config, behaviour, n_episodes, controller_factory, seed, chunk_size)
    t0 = time.perf_counter()
    if map_tasks is None:
        workers = 1
        results = []
        with tqdm(total=n_episodes, unit="ep", disable=not progress, desc=f"{behaviour} episodes") as bar:
            for task in tasks:
                results.append(run_chunk(task))
                bar.update(task.size)
    else:
        results = map_tasks(run_chunk, tasks)
    wall = time.perf_counter() - t0
    log.info("batch of %d %s episodes in %.2f s on %s worker(s)", n_episodes, behaviour, wall, workers or "?")
    return assemble_batch(results, wall, workers)
