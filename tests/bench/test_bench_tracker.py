"""Tracker time per frame (must keep up with 30 Hz, 33.3 ms, with room to spare).

Measures, on recorded simulated frames: the human pipeline per skeleton frame (depth decode
and back-projection included, both corrections on), object detection per depth frame, and
the simulated Kinect's rendering per frame. Baseline: the raw pipeline with both corrections
off (decode + body dimensions only). Writes out/bench/tracker.json.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import msgspec
import numpy as np
import pytest

from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from services.tracker.config import TrackerConfig
from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
from services.tracker.episodes import run_episode
from services.tracker.pointcloud import depth_frame_from_message

pytestmark = pytest.mark.bench
FRAME_BUDGET_MS = 1000.0 / 30.0


def _stats(samples_s: list[float]) -> dict[str, float]:
    ms = np.asarray(samples_s) * 1000.0
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "n": int(ms.size)}


def test_bench_tracker():
    arm = ArmGeometry()
    frames = list(run_episode(1, arm)) + list(run_episode(2, arm))
    results = {}
    for name, cfg in (
        ("pipeline, both corrections", TrackerConfig()),
        ("pipeline, lag on every frame", TrackerConfig(lag_min_speed_m_s=0.0)),
        ("baseline: no corrections", TrackerConfig(lag_correction=False, proximity_filter=False)),
    ):
        pipe = TrackerPipeline(cfg, arm)
        hand, obj = [], []
        for f in frames:
            t0 = time.perf_counter()
            pipe.on_joint_state(np.asarray(f.joint_state.position_rad), f.t_s)
            pipe.on_depth(depth_frame_from_message(f.depth, f.t_s))
            pipe.on_skeleton(skeleton_frame_from_message(f.skeleton, f.t_s))
            pipe.cloud()  # the back-projection, even when no correction needs it
            t1 = time.perf_counter()
            det = pipe.detect_object(force=True)
            t2 = time.perf_counter()
            hand.append(t1 - t0)
            if det is not None:
                obj.append(t2 - t1)
        results[name] = _stats(hand)
        if name == "pipeline, both corrections":
            results["object detection (per run)"] = _stats(obj)
    sim = KinectSim(seed=0, scenario=KinectScenario(hand_target_base_m=(0.75, -0.26, 0.05)), arm_geometry=arm)
    q = np.array(frames[0].joint_state.position_rad)
    render = []
    for k in range(90):
        t0 = time.perf_counter()
        sim.step(k / 30.0, q)
        render.append(time.perf_counter() - t0)
    results["simulated Kinect step (render)"] = _stats(render)
    base = results["baseline: no corrections"]["median_ms"]
    for r in results.values():
        r["ratio_vs_baseline"] = r["median_ms"] / base
    # Worst case per frame: the pipeline plus an object detection every 3rd depth frame.
    per_frame = results["pipeline, both corrections"]["p99_ms"] + results["object detection (per run)"]["median_ms"] / 3.0
    results["tracker p99 + amortised object detection"] = {"ms": per_frame, "budget_ms": FRAME_BUDGET_MS}
    print("\n%-40s %10s %10s %8s" % ("tracker bench", "median ms", "p99 ms", "ratio"))
    for name, r in results.items():
        if "median_ms" in r:
            print("%-40s %10.2f %10.2f %8.2f" % (name, r["median_ms"], r["p99_ms"], r["ratio_vs_baseline"]))
    print("%-40s %10.2f (budget %.1f ms at 30 Hz)" % ("tracker p99 + object every 3rd frame", per_frame, FRAME_BUDGET_MS))
    out = Path("out/bench")
    out.mkdir(parents=True, exist_ok=True)
    (out / "tracker.json").write_text(json.dumps(results, indent=2))
    median_frame = results["pipeline, both corrections"]["median_ms"] + results["object detection (per run)"]["median_ms"] / 3.0
    results["tracker median + amortised object detection"] = {"ms": median_frame, "budget_ms": FRAME_BUDGET_MS}
    (out / "tracker.json").write_text(json.dumps(results, indent=2))
    print("%-40s %10.2f" % ("tracker median + object every 3rd frame", median_frame))
    # Generous targets (shared, noisy machine): median with 2x room, p99 within the budget.
    assert median_frame < FRAME_BUDGET_MS / 2, "tracker median does not keep up with 30 Hz with 2x room"
    assert per_frame < FRAME_BUDGET_MS, "tracker p99 exceeds the 30 Hz frame budget"
