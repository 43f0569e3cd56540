"""Benchmark: one controller step, scalar (1 episode) and vectorised (10 000 episodes).

Run: python -m pytest tests/bench/test_bench_gripper_step.py -m bench -s
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from handover_model.grip import SensorSample
from services.gripper.controllers.fail_safe import FS_PRESETS, fail_safe_law
from services.gripper.controllers.registry import make_controller

OUT = Path("out/bench/gripper.json")


def _sample(n: int, rng) -> SensorSample:
    return SensorSample(
        time_s=0.0, force_x_n=rng.normal(1, 1, n), force_y_n=rng.normal(2, 0.5, n), accel_y_m_s2=rng.normal(0, 2, n),
        slip_velocity_x_m_s=np.zeros(n), slip_velocity_y_m_s=np.zeros(n), optical_valid=np.ones(n, dtype=bool),
        grip_force_n=np.zeros(n),
    )


def _time(fn, repeats: int) -> np.ndarray:
    out = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter_ns()
        fn()
        out[i] = time.perf_counter_ns() - t0
    return out / 1e3  # µs


@pytest.mark.bench
def test_bench_gripper_step():
    rng = np.random.default_rng(0)
    rows = {}
    for name in ("FS1", "HI", "displacement"):
        for n, repeats in ((1, 20000), (10_000, 500)):
            c = make_controller(name)
            c.reset(n)
            s = _sample(n, rng)
            c.step(s)
            us = _time(lambda: c.step(s), repeats)
            rows[f"{name} n={n}"] = {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
                                     "per_episode_ns": float(np.median(us) * 1e3 / n)}
    # Baseline: the bare eq 3.19 expression on scalars (Python floats) and on the same arrays.
    p = FS_PRESETS["FS1"]
    us = _time(lambda: min(max(0.13 * (10 * 2.0 + 3 * 0.1 - 3 * 1.0 - 15) + 0.87 * 5.0, 0.0), 140.0), 20000)
    rows["baseline: scalar eq 3.19 in Python"] = {"median_us": float(np.median(us)),
                                                  "p99_us": float(np.percentile(us, 99)),
                                                  "per_episode_ns": float(np.median(us) * 1e3)}
    s = _sample(10_000, rng)
    g = np.zeros(10_000)
    us = _time(lambda: fail_safe_law(p, s.force_x_n, s.force_y_n, s.accel_y_m_s2, g), 500)
    rows["baseline: fail_safe_law n=10000"] = {"median_us": float(np.median(us)),
                                               "p99_us": float(np.percentile(us, 99)),
                                               "per_episode_ns": float(np.median(us) * 1e3 / 1e4)}

    ratio_vec = rows["FS1 n=10000"]["median_us"] / rows["baseline: fail_safe_law n=10000"]["median_us"]
    ratio_scalar = rows["FS1 n=1"]["median_us"] / rows["baseline: scalar eq 3.19 in Python"]["median_us"]
    print(f"\n{'case':40s} {'median µs':>10s} {'p99 µs':>10s} {'ns/episode':>11s}")
    for k, v in rows.items():
        print(f"{k:40s} {v['median_us']:10.2f} {v['p99_us']:10.2f} {v['per_episode_ns']:11.2f}")
    print(f"FS1 controller / bare law (10 000 episodes): {ratio_vec:.2f}x; "
          f"FS1 n=1 / Python scalar law: {ratio_scalar:.1f}x")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"rows": rows, "ratio_fs1_vs_bare_law_10000": ratio_vec,
                               "ratio_fs1_n1_vs_python_scalar": ratio_scalar}, indent=2))
    # generous target: one live step must fit far inside a 1 kHz period
    assert rows["FS1 n=1"]["p99_us"] < 1000.0
