"""Benchmark: DJT plan time at 1 cm resolution (DESIGN §9 target: median ≤ 5 ms).

Run: python -m pytest tests/bench/test_bench_planner.py -m bench -s
Writes out/bench/planner.json.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN
from services.planner.djt.cost import djt_cost
from services.planner.djt.optimum import optimise
from services.planner.djt.settings import DJTSettings
from services.planner.transfer_plan import DyadGeometry, build_dyad, plan_transfer
from tests.bench._report import save

pytestmark = pytest.mark.bench

TARGET_MEDIAN_MS = 5.0


def _timings_ms(fn, n: int, warmup: int = 5) -> np.ndarray:
    for _ in range(warmup):
        fn()
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn()
        out[i] = (time.perf_counter() - t0) * 1e3
    return out


def test_bench_djt_plan_time():
    settings = DJTSettings(grid_resolution_m=0.01)
    robot = DyadGeometry(giver_is_robot=True)
    sitting = replace(FIGURE3_ACTOR, posture="sitting")
    dyad = build_dyad(ROBOT_AS_HUMAN, FIGURE3_ACTOR, robot)

    def brute_force_1mm():
        # The simple baseline: the same accuracy from a 1 mm grid, no refinement.
        xs = np.arange(-0.3, 0.3, 0.001)
        zs = np.arange(0.0, 1.0, 0.001)
        xx, zz = np.meshgrid(xs, zs)
        cost, _ = djt_cost(dyad, xx, zz, 0.2, settings)
        return np.unravel_index(np.argmin(cost), cost.shape)

    cases = {
        "plan_transfer, robot giver + standing receiver (1 cm grid + SLSQP)":
            (lambda: plan_transfer(ROBOT_AS_HUMAN, FIGURE3_ACTOR, 0.2, robot, settings), 300),
        "plan_transfer, robot giver + sitting receiver (1 cm grid + SLSQP)":
            (lambda: plan_transfer(ROBOT_AS_HUMAN, sitting, 0.2, robot, settings), 300),
        "optimise, Fig. 3 dyad (1 cm grid + SLSQP)":
            (lambda: optimise(dyad, 0.2, settings), 300),
        "grid only, 1 cm (no refinement)":
            (lambda: optimise(dyad, 0.2, replace(settings, refine=False)), 300),
        "baseline: brute-force 1 mm grid":
            (brute_force_1mm, 20),
    }
    results = {}
    for name, (fn, n) in cases.items():
        t = _timings_ms(fn, n)
        results[name] = {"n": n, "median_ms": float(np.median(t)), "p99_ms": float(np.percentile(t, 99)),
                         "mean_ms": float(t.mean())}
    main = results["plan_transfer, robot giver + standing receiver (1 cm grid + SLSQP)"]
    base = results["baseline: brute-force 1 mm grid"]
    ratio = base["median_ms"] / main["median_ms"]
    opt_refined, _ = optimise(dyad, 0.2, settings)
    iz, ix = brute_force_1mm()
    xs = np.arange(-0.3, 0.3, 0.001)
    zs = np.arange(0.0, 1.0, 0.001)
    px, pz = opt_refined.position_task_m
    accuracy_mm = float(np.hypot(px - xs[ix], pz - zs[iz]) * 1e3)
    print()
    print(f"{'case':72s} {'median ms':>10s} {'p99 ms':>10s}")
    for name, r in results.items():
        print(f"{name:72s} {r['median_ms']:10.3f} {r['p99_ms']:10.3f}")
    print(f"baseline / plan median ratio: {ratio:.1f}x; plan vs 1 mm brute force: {accuracy_mm:.2f} mm apart")
    save("planner", {
        "target": {"median_ms": TARGET_MEDIAN_MS},
        "cases_ms": results,
        "baseline_over_plan_median_ratio": ratio,
        "plan_vs_brute_force_1mm_distance_mm": accuracy_mm,
    })
    # Generous on a shared, noisy 2-core machine: three times the DESIGN target.
    assert main["median_ms"] <= 3 * TARGET_MEDIAN_MS
