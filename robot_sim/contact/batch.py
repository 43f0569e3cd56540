"""Monte-Carlo batch runner: vectorised over episodes, seedable, parallel, with progress.

Episodes are cut into chunks of `chunk_size`; each chunk is one vectorised run
(`episode.run_vectorised`) on numpy arrays of shape (chunk,). Chunk i gets its own seed,
spawned from the run's seed (`numpy.random.SeedSequence(seed).spawn`), which samples its
receivers and drives its sensor noise, so the result depends on (seed, chunk_size) only,
never on the number of worker processes or on their timing. Chunks run on a process pool
(`workers` processes, default: every core) and a tqdm bar counts finished episodes.

The controller is built in each worker by `controller_factory()` (a picklable callable:
a class, or `functools.partial` of one). It steps every `period_s` of plant time
(`episode.run_vectorised`), whatever the gripper's position loop does: the loop latches the
newest command at its own rate (25 Hz by default). A controller slower than
`config.control_period_s` (a gripper loop faster than the controller) gets a warning: the
loop would latch the same command several times.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from tqdm import tqdm

from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.episode import run_vectorised
from handover_model.grip import GripController
from robot_sim.contact.outcome import BatchOutcome
from robot_sim.contact.receiver import ReceiverParams, sample_behaviours, stack_receivers

__all__ = ["BatchResult", "run_batch", "chunk_receivers"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BatchResult:
    """Outcomes of a batch (in episode order), the receivers used, and the wall time (s)."""

    outcome: BatchOutcome
    receivers: ReceiverParams
    wall_time_s: float
    workers: int

    @property
    def episodes_per_s(self) -> float:
        """Throughput of this run (episodes per wall-clock second)."""
        return len(self.outcome) / self.wall_time_s if self.wall_time_s > 0 else float("inf")


def chunk_receivers(behaviour: str, n: int, seed_seq: np.random.SeedSequence, weight_n: float) -> ReceiverParams:
    """The stacked receivers of one chunk (reproducible from the chunk's seed)."""
    rng = np.random.default_rng(seed_seq.spawn(1)[0])
    return stack_receivers(sample_behaviours(behaviour, n, rng, weight_n=weight_n))


def _run_chunk(args) -> tuple[int, BatchOutcome, ReceiverParams]:
    index, config, behaviour, n, seed_seq, factory = args
    receivers = chunk_receivers(behaviour, n, seed_seq, config.obj.weight_n)
    noise_seed = seed_seq.spawn(2)[1]
    outcome = run_vectorised(config, receivers, factory(), seed=noise_seed)
    return index, outcome, receivers


def run_batch(
    config: SimConfig,
    behaviour: str,
    n_episodes: int,
    controller_factory: Callable[[], GripController],
    seed: int = 0,
    workers: int | None = None,
    chunk_size: int = 500,
    progress: bool = True,
) -> BatchResult:
    """Run `n_episodes` randomised episodes of `behaviour` (a kind of
    `robot_sim.contact.sampling.KINDS`, "mixed" or "mixed-wide") under the controller, and
    judge each from ground truth."""
    if n_episodes < 1:
        raise ContactSimError(f"n_episodes must be >= 1, got {n_episodes}")
    if chunk_size < 1:
        raise ContactSimError(f"chunk_size must be >= 1, got {chunk_size}")
    workers = (os.cpu_count() or 1) if workers is None else int(workers)
    if workers < 1:
        raise ContactSimError(f"workers must be >= 1, got {workers}")
    sample_behaviours(behaviour, 0, np.random.default_rng(0))  # validates the name before any work
    period_s = float(getattr(controller_factory(), "period_s", 0.01))
    if period_s > config.control_period_s * (1.0 + 1e-9):
        log.warning("the controller steps every %.4g s but the gripper loop latches every %.4g s: "
                    "build it with period_s=config.control_period_s", period_s, 1.0 / config.gripper.loop_rate_hz)
    sizes = [min(chunk_size, n_episodes - i) for i in range(0, n_episodes, chunk_size)]
    seqs = np.random.SeedSequence(seed).spawn(len(sizes))
    jobs = [(i, config, behaviour, s, seqs[i], controller_factory) for i, s in enumerate(sizes)]
    results: dict[int, tuple[BatchOutcome, ReceiverParams]] = {}
    t0 = time.perf_counter()
    bar = tqdm(total=n_episodes, unit="ep", disable=not progress, desc=f"{behaviour} episodes")
    try:
        if workers == 1 or len(jobs) == 1:
            for job in jobs:
                i, out, rec = _run_chunk(job)
                results[i] = (out, rec)
                bar.update(len(out))
        else:
            method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
            with mp.get_context(method).Pool(processes=min(workers, len(jobs))) as pool:
                for i, out, rec in pool.imap_unordered(_run_chunk, jobs):
                    results[i] = (out, rec)
                    bar.update(len(out))
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    outcome = BatchOutcome.concatenate([results[i][0] for i in range(len(jobs))])
    receivers = stack_receivers([results[i][1].episode(j) for i in range(len(jobs)) for j in range(sizes[i])])
    log.info("batch of %d %s episodes in %.2f s on %d worker(s)", n_episodes, behaviour, wall, workers)
    return BatchResult(outcome=outcome, receivers=receivers, wall_time_s=wall, workers=workers)
