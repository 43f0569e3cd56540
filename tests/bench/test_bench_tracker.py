"""Tracker time per frame: the lean depth processing against the whole-cloud reference.

Per 30 Hz frame, as the node does it: joint state, depth decode, skeleton (lag correction and
proximity filter) and, on every 3rd depth frame, the object detection. Measured on the same
frames in the same run, frame by frame alternately:

- new: only the pixels needed are back-projected (the hand's box window, the pixels above
  the floor for the table plane, the table region for the object);
- baseline: `tests.unit.tracker.per_frame_reference.HeadPipeline`, the code before both CPU
  rounds (the whole depth image back-projected per frame, the box and object searched in it;
  the body window stacked and reduced with numpy's generic routines on every frame, one
  `np.linalg.norm` call per segment, one array per joint of a message).

Frame sets: two reaching episodes (`run_episode`, 240 frames) and the idle scene (the
receiver standing, the arm at home, 90 frames, as `handover-up --job none` shows it).
Configurations: the default (lag correction only while the hand moves) and the lag correction
on every frame; plus the object detection alone. Writes out/bench/tracker.json.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import pytest

from bus_schema.messages import DepthImage, JointState, Skeleton
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from services.tracker.config import TrackerConfig
from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
from services.studies.tracker.episodes import run_episode
from services.tracker.pointcloud import depth_frame_from_message
from tests.bench._report import save, summarize, table
from tests.unit.tracker.per_frame_reference import HeadPipeline, reference_skeleton_frame_from_message

pytestmark = pytest.mark.bench
FRAME_BUDGET_MS = 1000.0 / 30.0


@dataclass(frozen=True)
class Frame:
    t_s: float
    joint_state: JointState
    depth: DepthImage
    skeleton: Skeleton


def _idle_frames(arm: ArmGeometry, n: int = 90) -> list[Frame]:
    sim = KinectSim(seed=2, scenario=KinectScenario(), arm_geometry=arm)
    q = list(RIGHT_ARM_HOME_RAD)
    js = JointState(seq=0, stamp_ns=0, source="sim", names=list(RIGHT_ARM_JOINTS), position_rad=q,
                    velocity_rad_s=[0.0] * 7)
    out = []
    for k in range(n):
        f = sim.step(k / 30.0, np.array(q))
        out.append(Frame(k / 30.0, js, DepthImage(seq=k, stamp_ns=0, source="sim", **f.depth_fields),
                         Skeleton(seq=k, stamp_ns=0, source="sim", **f.skeleton_fields)))
    return out


def _to_skeleton(pipe: TrackerPipeline):
    return reference_skeleton_frame_from_message if isinstance(pipe, HeadPipeline) else skeleton_frame_from_message


def _frame_ms(pipe: TrackerPipeline, f: Frame, detect: str) -> float:
    """One frame's processing time (ms); `detect`: "due" (every 3rd depth frame), "never"."""
    t0 = time.perf_counter()
    pipe.on_joint_state(np.asarray(f.joint_state.position_rad), f.t_s)
    pipe.on_depth(depth_frame_from_message(f.depth, f.t_s))
    pipe.on_skeleton(_to_skeleton(pipe)(f.skeleton, f.t_s))
    if detect == "due":
        pipe.detect_object()
    return (time.perf_counter() - t0) * 1e3


def _detect_ms(pipe: TrackerPipeline, f: Frame) -> float:
    pipe.on_joint_state(np.asarray(f.joint_state.position_rad), f.t_s)
    pipe.on_depth(depth_frame_from_message(f.depth, f.t_s))
    pipe.on_skeleton(_to_skeleton(pipe)(f.skeleton, f.t_s))
    t0 = time.perf_counter()
    pipe.detect_object(force=True)
    return (time.perf_counter() - t0) * 1e3


def _compare(frames: list[Frame], cfg: TrackerConfig, arm: ArmGeometry, what: str) -> tuple[list[float], list[float]]:
    """(new, baseline) samples (ms), the two pipelines run alternately frame by frame."""
    new, ref = TrackerPipeline(cfg, arm), HeadPipeline(cfg, arm)
    samples: tuple[list[float], list[float]] = ([], [])
    for k, f in enumerate(frames):
        order = ((0, new), (1, ref)) if k % 2 == 0 else ((1, ref), (0, new))
        for i, pipe in order:
            samples[i].append(_detect_ms(pipe, f) if what == "detect" else _frame_ms(pipe, f, what))
    return samples


def test_bench_tracker():
    arm = ArmGeometry()
    sets = {"reach": list(run_episode(1, arm)) + list(run_episode(2, arm)), "idle": _idle_frames(arm)}
    sets["reach"] = [Frame(f.t_s, f.joint_state, f.depth, f.skeleton) for f in sets["reach"]]
    cases = [
        ("frame, default config", TrackerConfig(), "due"),
        ("frame, lag on every frame", TrackerConfig(lag_min_speed_m_s=0.0), "due"),
        ("hand only, lag on every frame", TrackerConfig(lag_min_speed_m_s=0.0), "never"),
        ("object detection only", TrackerConfig(), "detect"),
    ]
    results: dict[str, dict] = {}
    rows = []
    for set_name, frames in sets.items():
        for case, cfg, what in cases:
            _compare(frames[:10], cfg, arm, what)  # warm-up (caches, allocator)
            new, ref = _compare(frames, cfg, arm, what)
            s_new, s_ref = summarize(new), summarize(ref)
            name = f"{set_name}: {case}"
            results[name] = {"new_ms": s_new, "baseline_ms": s_ref,
                             **{f"ratio_{k}": s_new[k] / s_ref[k] for k in ("median", "p99", "mean")}}
            rows.append((name, *(f"{s[k]:.2f}" for s in (s_new, s_ref) for k in ("median", "p99", "mean")),
                         *(f"{results[name][f'ratio_{k}']:.2f}" for k in ("median", "p99", "mean"))))
    print("\n" + table(rows, ("tracker per frame (ms)", "new median", "new p99", "new mean", "baseline median",
                              "baseline p99", "baseline mean", "ratio median", "ratio p99", "ratio mean")))
    save("tracker", results)
    for name, r in results.items():
        # The mean is the CPU per frame (the median frame of the default configuration runs
        # neither the lag correction nor a detection: there both pipelines do the same work).
        assert r["ratio_mean"] < 0.8, f"{name}: not clearly cheaper than the whole cloud"
        # Generous (shared, noisy machine): the p99 frame fits the 30 Hz budget with 2x room.
        assert r["new_ms"]["p99"] < FRAME_BUDGET_MS / 2, f"{name}: p99 over half the 30 Hz frame budget"
