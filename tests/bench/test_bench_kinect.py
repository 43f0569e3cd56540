"""Simulated Kinect: cost of one frame (depth rendering, noise, skeleton), on this machine.

The Kinect renders 320×240 depth at 30 Hz in its own process beside the safety services
on two cores, so its CPU time is the stack's largest single share. Measured here:
`KinectSim.step` (the whole frame), its depth render with the static scene (floor and table)
cast once and drawn behind (what `step` does), and the baseline measured in the same run:
the same render casting the whole scene every frame. Writes out/bench/kinect.json.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from robot_sim import scene
from robot_sim.kinect import KinectScenario, KinectSim
from robot_sim.kinect.sim import object_box
from tests.bench._report import save, summarize, table

pytestmark = pytest.mark.bench
N_FRAMES = 300


def _ms(samples_s: list[float]) -> dict[str, float]:
    return {k: (v * 1e3 if k != "n" else v) for k, v in summarize(samples_s).items()}


def test_bench_kinect_frame():
    sim = KinectSim(seed=0, scenario=KinectScenario(hand_target_base_m=(0.75, -0.26, 0.05), reach_start_s=1.0))
    rng = np.random.default_rng(0)
    postures = rng.uniform(-0.8, 0.8, (N_FRAMES, 7))
    step, cached, whole = [], [], []
    for k in range(N_FRAMES):
        t_s = k / 30.0
        q = postures[k]
        t0 = time.perf_counter()
        sim.step(t_s, q)
        step.append(time.perf_counter() - t0)
        joints = sim.body.joints(sim.true_hand(t_s))
        moving = sim.body.capsules(joints) + sim.arm.capsules(q)
        obj = object_box(scene.OBJECT_PICK_BASE_M, sim.scenario.object_size_m)
        t0 = time.perf_counter()
        a = sim.renderer.render(moving, [obj], background=sim._static_depth_m)
        t1 = time.perf_counter()
        b = sim.renderer.render(moving + sim._table_legs, [sim._table_top, obj],
                                floor_z_m=-scene.BASE_HEIGHT_ABOVE_FLOOR_M)
        t2 = time.perf_counter()
        cached.append(t1 - t0)
        whole.append(t2 - t1)
        assert np.array_equal(a, b), f"frame {k}: the cached background changed the image"
    results = {"KinectSim.step (whole frame)": _ms(step),
               "render, static scene cached (used)": _ms(cached),
               "baseline: render, whole scene every frame": _ms(whole)}
    base = results["baseline: render, whole scene every frame"]["median"]
    for r in results.values():
        r["ratio_vs_baseline"] = r["median"] / base
    rows = [(name, f"{r['median']:.2f}", f"{r['p99']:.2f}", f"{r['ratio_vs_baseline']:.2f}")
            for name, r in results.items()]
    print("\n" + table(rows, ("simulated Kinect, per frame", "median ms", "p99 ms", "ratio vs baseline")))
    save("kinect", results)
    # The frame must fit the 30 Hz period with room for the rest of the stack (generous: noisy machine).
    assert results["KinectSim.step (whole frame)"]["median"] < 1000.0 / 30.0 / 2
    assert results["render, static scene cached (used)"]["median"] < base
