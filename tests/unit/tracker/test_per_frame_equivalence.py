"""The tracker's outputs equal those of the code before the per-frame CPU work, bit for bit:
the body estimator (and its cached estimate), the joints of a message, and the whole pipeline
(`per_frame_reference.HeadPipeline`: the previous skeleton code on the whole-cloud depth
reference) over a reaching episode and the idle scene, with the person lost and found again."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bus_schema.messages import DepthImage, JointState, Skeleton
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from services.tracker.body import REQUIRED_JOINTS, BodyDimensionEstimator
from services.tracker.config import TrackerConfig
from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
from services.studies.tracker.episodes import run_episode
from services.tracker.node import human_fields, object_fields
from services.tracker.pointcloud import depth_frame_from_message
from tests.unit.tracker.per_frame_reference import (
    HeadPipeline,
    ReferenceBodyDimensionEstimator,
    reference_skeleton_frame_from_message,
)


def assert_same(got, ref, where: str = "") -> None:
    """Equal field by field; floats and arrays bit for bit."""
    if dataclasses.is_dataclass(got):
        assert type(got).__name__ == type(ref).__name__, where
        for f in dataclasses.fields(got):
            assert_same(getattr(got, f.name), getattr(ref, f.name), f"{where}.{f.name}")
    elif isinstance(got, dict):
        assert got.keys() == ref.keys(), where
        for k in got:
            assert_same(got[k], ref[k], f"{where}[{k}]")
    elif isinstance(got, (tuple, list)) and not all(isinstance(v, (int, float, np.floating)) for v in got):
        assert type(got) is type(ref) and len(got) == len(ref), where
        for i, (g, r) in enumerate(zip(got, ref)):
            assert_same(g, r, f"{where}[{i}]")
    elif isinstance(got, (float, np.ndarray, np.floating, tuple, list)):
        g, r = np.asarray(got), np.asarray(ref)
        assert g.shape == r.shape and g.astype(float).tobytes() == r.astype(float).tobytes(), (where, got, ref)
    else:
        assert got == ref, (where, got, ref)


def _joints(rng: np.random.Generator, base: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    joints = {n: v + rng.normal(0.0, 0.05, 3) for n, v in base.items()}
    r = rng.random()
    if r < 0.03:
        joints.pop(REQUIRED_JOINTS[int(rng.integers(len(REQUIRED_JOINTS)))])  # frame ignored
    elif r < 0.05:
        joints["head"] = np.array([np.nan, 0.0, 1.0])  # frame ignored
    elif r < 0.06:
        joints["left_hip"] = joints["left_knee"].copy()  # a zero-length thigh
    return joints


@pytest.mark.parametrize("window", [1, 7, 90])
def test_body_estimate_and_its_cache_equal_the_previous_estimator(window):
    """Every frame: the (cached) estimate, a fresh computation and the previous estimator's
    agree; the estimate changes on most frames, so a stale cache would show."""
    rng = np.random.default_rng(window)
    new, ref = BodyDimensionEstimator(-0.9, window), ReferenceBodyDimensionEstimator(-0.9, window)
    names = REQUIRED_JOINTS + ("torso", "neck")
    base = {n: rng.normal(0.0, 0.5, 3) for n in names}
    changes, previous = 0, None
    for k in range(400):
        if k % 150 == 149:
            new.reset()
            ref.reset()
            base = {n: rng.normal(0.0, 0.5, 3) for n in names}
        joints = _joints(rng, base)
        assert new.update(joints) == ref.update(joints)
        cached = new.estimate()
        assert_same(cached, ref.estimate(), f"frame {k}")
        assert_same(new._compute(), cached, f"frame {k} uncached")
        assert new.estimate() is cached  # asked again, unchanged window: the same estimate
        changes += previous is not None and cached != previous
        previous = cached
    assert changes > 300


def test_joints_of_a_message_equal_one_array_per_joint():
    rng = np.random.default_rng(5)
    sim = KinectSim(seed=3, scenario=KinectScenario())
    for k in range(5):
        f = sim.step(k / 30.0, np.array(RIGHT_ARM_HOME_RAD))
        msg = Skeleton(seq=k, stamp_ns=0, source="t", **f.skeleton_fields)
        t = float(rng.uniform(0, 10))
        got, ref = skeleton_frame_from_message(msg, t), reference_skeleton_frame_from_message(msg, t)
        assert (got.tracked, got.t_s, list(got.joints_m)) == (ref.tracked, ref.t_s, list(ref.joints_m))
        for name, v in got.joints_m.items():
            assert_same(v, ref.joints_m[name], name)
            assert v.shape == (3,) and v.dtype == np.float64 and not v.flags.writeable
    empty = Skeleton(seq=0, stamp_ns=0, source="t", tracked=True, user_id=1, joints=[])
    assert skeleton_frame_from_message(empty, 0.0).tracked is False


@pytest.fixture(scope="module")
def arm():
    return ArmGeometry()


@pytest.fixture(scope="module")
def scenes(arm):
    """(t, joint state, depth, skeleton) frames: a reaching episode (the arm moves, the hand
    comes within the proximity hold) and the idle scene (the receiver standing, the arm at
    home); every 37th skeleton untracked (the person lost and found again)."""
    reach = [(f.t_s, f.joint_state, f.depth, f.skeleton) for f in run_episode(5, arm)]
    sim = KinectSim(seed=2, scenario=KinectScenario(), arm_geometry=arm)
    q = list(RIGHT_ARM_HOME_RAD)
    js = JointState(seq=0, stamp_ns=0, source="t", names=list(RIGHT_ARM_JOINTS), position_rad=q,
                    velocity_rad_s=[0.0] * 7)
    idle = []
    for k in range(100):
        f = sim.step(k / 30.0, np.array(q))
        idle.append((k / 30.0, js, DepthImage(seq=k, stamp_ns=0, source="t", **f.depth_fields),
                     Skeleton(seq=k, stamp_ns=0, source="t", **f.skeleton_fields)))
    lost = Skeleton(seq=0, stamp_ns=0, source="t", tracked=False, user_id=0, joints=[])
    return {name: [(t, j, d, lost if i % 37 == 36 else s) for i, (t, j, d, s) in enumerate(frames)]
            for name, frames in (("reach", reach), ("idle", idle))}


@pytest.mark.parametrize("scene", ["reach", "idle"])
@pytest.mark.parametrize("config", [TrackerConfig(proximity_filter=True, lag_min_speed_m_s=0.35),
                                    TrackerConfig(proximity_filter=True, lag_min_speed_m_s=0.0), TrackerConfig()],
                         ids=["both_corrections", "lag_always", "default"])
def test_pipeline_outputs_equal_the_previous_pipeline(arm, scenes, scene, config):
    new, ref = TrackerPipeline(config, arm), HeadPipeline(config, arm)
    seen: set[str] = set()
    for i, (t, js, depth, skeleton) in enumerate(scenes[scene]):
        outs = []
        for pipe, to_frame in ((new, skeleton_frame_from_message), (ref, reference_skeleton_frame_from_message)):
            pipe.on_joint_state(np.asarray(js.position_rad), t)
            pipe.on_depth(depth_frame_from_message(depth, t))
            est = pipe.on_skeleton(to_frame(skeleton, t))
            det = pipe.detect_object()
            late = pipe.human_state(t + (0.6 if i % 29 == 28 else 0.01))  # now and then stale
            outs.append((est, det, human_fields(late), None if det is None else object_fields(det, 0.2)))
        assert_same(outs[0], outs[1], f"{scene} frame {i}")
        seen.add(outs[0][0].correction)
        seen.add(outs[0][0].body.posture)
    assert {"standing", "sitting"} & seen  # a body estimate was made
    if scene == "reach" and config.proximity_filter:
        assert {"proximity_hold", "lag+proximity_hold"} & seen
    if scene == "reach" and config.lag_min_speed_m_s == 0.0:
        assert {"lag", "lag+proximity_hold"} & seen
