"""Benchmark of the closed loop on MuJoCo (`robot_sim.contact.crosscheck.closed_loop`) against
our plant's one-episode run (`robot_sim.contact.episode.run_episode`, the baseline), the same
3.5 s episode, controller and noise seed.

Run: python -m pytest tests/bench/test_bench_mujoco_loop.py -m bench -s
Writes out/bench/mujoco_loop.json.
"""

from __future__ import annotations

import time

import pytest

pytest.importorskip("mujoco", reason="the `mujoco` wheel is not installed here")

from robot_sim.contact.config import ObjectParams, SimConfig  # noqa: E402
from robot_sim.contact.crosscheck.closed_loop import run_mujoco_episode  # noqa: E402
from robot_sim.contact.episode import run_episode  # noqa: E402
from robot_sim.contact.receiver import taking  # noqa: E402
from services.gripper.controllers.registry import make_controller  # noqa: E402
from tests.bench._report import save, summarize, table  # noqa: E402


@pytest.mark.bench
def test_bench_mujoco_closed_loop():
    cfg = SimConfig(obj=ObjectParams(mu_static=0.6, mu_kinetic=0.6), duration_s=3.5)
    walls: dict[str, list[float]] = {"ours": [], "mujoco": []}
    for i in range(15):
        for plant, run in (("ours", run_episode), ("mujoco", run_mujoco_episode)):
            controller = make_controller("SG", period_s=cfg.control_period_s)
            t0 = time.perf_counter()
            run(cfg, taking(), controller, seed=i)
            walls[plant].append(time.perf_counter() - t0)
    results = {plant: {**summarize(w), "episodes_per_s_median": 1.0 / summarize(w)["median"]}
               for plant, w in walls.items()}
    results["mujoco_over_ours_median"] = results["mujoco"]["median"] / results["ours"]["median"]
    rows = [(plant, f"{r['median'] * 1e3:.1f} ms", f"{r['p99'] * 1e3:.1f} ms", f"{r['episodes_per_s_median']:.1f}/s")
            for plant, r in ((p, results[p]) for p in ("ours", "mujoco"))]
    print(table(rows, ("plant (SG, taking, 3.5 s)", "median", "p99", "episodes/s")))
    print(f"MuJoCo / ours (median): {results['mujoco_over_ours_median']:.2f}")
    save("mujoco_loop", results)
    assert results["mujoco"]["median"] < 1.0  # one 3.5 s episode well under a second of wall time
