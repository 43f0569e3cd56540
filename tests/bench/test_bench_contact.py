"""Benchmark of the contact plant (DESIGN §9: ≥ 200× real time per episode; 10 000
Monte-Carlo episodes ≤ 2 min on 2 cores).

Run: python -m pytest tests/bench/test_bench_contact.py -m bench -s
Writes out/bench/contact.json.
"""

from __future__ import annotations

import functools
import time

import numpy as np
import pytest

from robot_sim.contact.batch import run_batch
from robot_sim.contact.config import SimConfig
from robot_sim.contact.controllers import ConstantGrip
from robot_sim.contact.episode import run_episode, run_vectorised
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import stack_receivers, taking

from services.studies.engine import run_tasks
from tests.bench._report import save, summarize, table


def _episode_walls(cfg: SimConfig, repeats: int) -> np.ndarray:
    walls = []
    for i in range(repeats):
        t0 = time.perf_counter()
        run_episode(cfg, taking(), ConstantGrip(10.0), seed=i)
        walls.append(time.perf_counter() - t0)
    return np.array(walls)


@pytest.mark.bench
def test_bench_contact():
    cfg = SimConfig(duration_s=3.5)
    results: dict = {}
    rows = []

    # 1. One episode, Python-float plant (the bridge's and the plots' path), with its trace.
    for dt in (0.001, 0.002):
        c = SimConfig(duration_s=3.5, dt_s=dt)
        walls = _episode_walls(c, 15)
        rtf = c.duration_s / walls
        s = summarize(walls)
        results[f"episode_scalar_dt{dt * 1000:g}ms"] = {**s, "rtf_median": float(np.median(rtf)),
                                                        "rtf_p1": float(np.percentile(rtf, 1))}
        rows.append((f"one episode, floats, dt={dt * 1000:g} ms", f"{s['median'] * 1e3:.1f} ms",
                     f"{s['p99'] * 1e3:.1f} ms", f"{np.median(rtf):.0f}x"))

    # Baseline: the same episode through the numpy plant with n = 1 (same equations).
    walls = []
    for i in range(3):
        t0 = time.perf_counter()
        run_vectorised(cfg, stack_receivers([taking()]), ConstantGrip(10.0), seed=i)
        walls.append(time.perf_counter() - t0)
    s = summarize(walls)
    results["episode_numpy_n1_baseline"] = {**s, "rtf_median": float(cfg.duration_s / s["median"])}
    results["scalar_over_numpy_n1_speedup"] = float(s["median"] / results["episode_scalar_dt1ms"]["median"])
    rows.append(("baseline: numpy plant, n=1", f"{s['median'] * 1e3:.1f} ms", f"{s['p99'] * 1e3:.1f} ms",
                 f"{cfg.duration_s / s['median']:.0f}x"))

    # 2. One plant step for real-time use (bridge): latency per step.
    plant = ContactPlant(cfg, taking(), seed=0, initial_grip_force_n=10.0)
    steps = np.empty(3000)
    for k in range(steps.size):
        t0 = time.perf_counter_ns()
        plant.step(10.0)
        steps[k] = time.perf_counter_ns() - t0
    s = summarize(steps / 1e9)
    results["plant_step_scalar"] = s
    rows.append(("one plant step (1 ms), floats", f"{s['median'] * 1e6:.1f} us", f"{s['p99'] * 1e6:.1f} us",
                 f"{1e-3 / s['median']:.0f}x"))

    # 3. Monte-Carlo batch: 10 000 mixed episodes, 2 workers of the studies' engine (with its start-up).
    on_engine = functools.partial(run_tasks, workers=2, show_progress=False)  # a local Dask cluster, 2 workers
    res = run_batch(cfg, "mixed", 10_000, functools.partial(ConstantGrip, 10.0), seed=0, workers=2,
                    chunk_size=500, progress=False, map_tasks=on_engine)
    per_ep_rtf = cfg.duration_s * len(res.outcome) / (res.wall_time_s * res.workers)
    results["batch_10000_mixed_2_workers"] = {"wall_s": res.wall_time_s, "episodes_per_s": res.episodes_per_s,
                                              "rtf_per_episode_per_core": per_ep_rtf,
                                              "summary": res.outcome.summary()}
    rows.append(("10 000 episodes, 2 workers", f"{res.wall_time_s:.1f} s", "-", f"{res.episodes_per_s:.0f} ep/s"))
    rows.append(("  = per episode per core", "-", "-", f"{per_ep_rtf:.0f}x"))

    print()
    print(table(rows, ("what", "median", "p99", "real-time factor / rate")))
    path = save("contact", results)
    print(f"wrote {path}")
    # Generous targets (DESIGN §9): the batch target; the single-episode floats path is
    # reported, not asserted (see docs/contact.md for why it misses 200x).
    assert res.wall_time_s <= 120.0
    assert per_ep_rtf >= 200.0
