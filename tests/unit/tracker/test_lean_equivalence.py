"""The lean depth processing gives the whole-cloud results: back-projection of windows and
pixel sets, the hand's box points, the lag-corrected hand and the object detection, over many
random simulated frames (random receivers, arm postures, objects, hands and camera poses)."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import DepthImage, Skeleton
from handover_model import scene
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from robot_sim.kinect.camera import KINECT_LOOK_AT_BASE_M, KINECT_POSITION_BASE_M, KinectCamera, look_at_rotation
from services.tracker.config import TrackerConfig
from services.tracker.core import TrackerPipeline, skeleton_frame_from_message
from services.tracker.objects import detect_object
from services.tracker.pointcloud import (
    backproject,
    backproject_pixels,
    backproject_window,
    base_z,
    box_pixel_window,
    box_points,
    depth_frame_from_message,
)
from tests.unit.tracker.whole_cloud_reference import (
    ReferencePipeline,
    reference_backproject,
    reference_detect_object,
    reference_human_points_near,
)

N_FRAMES = 60
#: Equal within floating tolerance (in practice bitwise: the same float32 arithmetic).
ATOL_M = 1e-9
FLOOR_Z_M = -scene.BASE_HEIGHT_ABOVE_FLOOR_M


@pytest.fixture(scope="module")
def arm():
    return ArmGeometry()


def _random_frames(arm, seed: int, n: int):
    """`n` random frames: (t_s, arm joints q (7,), depth message, the `KinectFrame`)."""
    rng = np.random.default_rng(seed)
    lim = arm.model.limits
    home = np.array(RIGHT_ARM_HOME_RAD)
    frames = []
    for k in range(n):
        look = KINECT_LOOK_AT_BASE_M + rng.normal(0.0, 0.08, 3)
        position = KINECT_POSITION_BASE_M + rng.normal(0.0, 0.04, 3)
        camera = KinectCamera(position_m=position, rotation=look_at_rotation(position, look))
        scenario = KinectScenario(
            height_m=float(rng.uniform(1.5, 2.0)), posture="standing" if rng.random() < 0.7 else "sitting",
            hand_target_base_m=tuple(scene.OBJECT_PICK_BASE_M + rng.uniform([-0.1, -0.3, 0.0], [0.3, 0.3, 0.4])),
            reach_start_s=0.0, reach_duration_s=1.0,
        )
        sim = KinectSim(seed=int(rng.integers(1 << 30)), scenario=scenario, camera=camera, arm_geometry=arm)
        q = np.clip(home + rng.normal(0.0, 0.5, 7), lim.lower_rad, lim.upper_rad)
        on_table = scene.OBJECT_PICK_BASE_M + np.array([rng.uniform(-0.15, 0.15), rng.uniform(-0.3, 0.3), 0.0])
        obj = on_table if rng.random() < 0.7 else arm.tool_position(q)
        t = float(rng.uniform(0.0, 1.5))
        f = sim.step(t, q, object_position_m=obj)
        frames.append((t, q, DepthImage(seq=k, stamp_ns=0, source="t", **f.depth_fields), f))
    return frames


@pytest.fixture(scope="module")
def frames(arm):
    return _random_frames(arm, seed=7, n=N_FRAMES)


def test_partial_back_projections_are_the_whole_cloud_at_those_pixels(frames):
    rng = np.random.default_rng(1)
    for _, _, msg, _ in frames[:10]:
        frame = depth_frame_from_message(msg, 0.0)
        ref, ref_valid = reference_backproject(frame)
        points, valid = backproject(frame)
        np.testing.assert_array_equal(points, ref)
        np.testing.assert_array_equal(valid, ref_valid)
        np.testing.assert_array_equal(base_z(frame), ref[..., 2])
        idx = rng.choice(ref_valid.size, 500, replace=False)
        np.testing.assert_array_equal(backproject_pixels(frame, idx), ref.reshape(-1, 3)[idx])
        rows, cols = slice(17, 90), slice(200, 311)
        win, win_valid = backproject_window(frame, rows, cols)
        np.testing.assert_array_equal(win, ref[rows, cols])
        np.testing.assert_array_equal(win_valid, ref_valid[rows, cols])


def test_box_window_holds_every_point_of_the_box(frames, arm):
    """Random boxes (around the hand, anywhere in the scene, around the camera itself): the
    window's points in the box are the whole cloud's, in the same order."""
    rng = np.random.default_rng(2)
    in_box_total = 0
    for _, q, msg, f in frames:
        frame = depth_frame_from_message(msg, 0.0)
        pipe = TrackerPipeline(TrackerConfig(), arm)
        pipe.on_joint_state(q, 0.0)
        pipe.on_depth(frame)
        caps, _ = pipe._robot(0.0)  # the arm's capsules and the gripper's clearance sphere
        centres = [f.truth.right_hand_m + rng.normal(0.0, 0.05, 3), rng.uniform([0.0, -1.2, -0.9], [1.6, 1.2, 1.0]),
                   frame.camera_position_m + rng.normal(0.0, 0.1, 3)]
        for centre in centres:
            half = float(rng.uniform(0.03, 0.3))
            rows, cols = box_pixel_window(frame, centre, half)
            ref = reference_human_points_near(frame, centre, half, caps, pipe.config.robot_point_margin_m)
            got = pipe._human_points_near(centre, half, 0.0)
            assert got.shape == ref.shape
            np.testing.assert_allclose(got, ref, rtol=0.0, atol=ATOL_M)
            in_box_total += len(ref)
            assert rows.stop - rows.start <= frame.depth_m.shape[0] and cols.stop - cols.start <= frame.depth_m.shape[1]
    assert in_box_total > 10_000  # the boxes were not empty


def test_a_box_that_is_not_finite_holds_no_point(frames):
    frame = depth_frame_from_message(frames[0][2], 0.0)
    for centre in ([np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0]):
        assert box_points(frame, np.array(centre), 0.12).shape == (0, 3)
        assert reference_human_points_near(frame, np.array(centre), 0.12, None, 0.0).shape == (0, 3)


def test_hand_box_window_is_small(frames):
    """The box around the hand (12 cm half edge) covers about a tenth of the image, not all of it."""
    areas = []
    for _, _, msg, f in frames:
        frame = depth_frame_from_message(msg, 0.0)
        rows, cols = box_pixel_window(frame, f.truth.right_hand_m, 0.12)
        areas.append((rows.stop - rows.start) * (cols.stop - cols.start) / frame.depth_m.size)
    assert np.median(areas) < 0.15


def test_object_detection_equals_the_whole_cloud_detection(frames, arm):
    found = 0
    for t, q, msg, f in frames:
        frame = depth_frame_from_message(msg, t)
        pipe = TrackerPipeline(TrackerConfig(), arm)
        pipe.on_joint_state(q, t)
        pipe.on_skeleton(skeleton_frame_from_message(Skeleton(seq=0, stamp_ns=0, source="t", **f.skeleton_fields), t))
        pipe.on_depth(frame)
        exclude = pipe._excluded_points
        for kwargs in ({}, {"exclude_points": exclude},
                       {"exclude_points": exclude, "min_height_m": 0.05, "min_pixels": 60}):
            got = detect_object(frame, FLOOR_Z_M, **kwargs)
            ref = reference_detect_object(frame, FLOOR_Z_M, **kwargs)
            assert (got.found, got.pixels, got.reason) == (ref.found, ref.pixels, ref.reason)
            assert got.table == ref.table
            np.testing.assert_allclose(got.position_m, ref.position_m, rtol=0.0, atol=ATOL_M)
            np.testing.assert_allclose(got.size_m, ref.size_m, rtol=0.0, atol=ATOL_M)
            found += got.found
    assert found > N_FRAMES  # most detections found an object


def test_pipeline_outputs_equal_the_whole_cloud_pipeline_over_episodes(arm):
    """The whole pipeline (lag correction on every frame, proximity filter, object detection
    on every 3rd depth frame) on random reaching episodes, frame by frame."""
    from services.studies.tracker.episodes import run_episode

    cfg = TrackerConfig(lag_min_speed_m_s=0.0)
    acted = 0
    for seed in (3, 4):
        new, ref = TrackerPipeline(cfg, arm), ReferencePipeline(cfg, arm)
        for f in run_episode(seed, arm):
            outs = []
            for pipe in (new, ref):
                pipe.on_joint_state(np.asarray(f.joint_state.position_rad), f.t_s)
                pipe.on_depth(depth_frame_from_message(f.depth, f.t_s))
                est = pipe.on_skeleton(skeleton_frame_from_message(f.skeleton, f.t_s))
                outs.append((est, pipe.detect_object()))
            (est, det), (est_ref, det_ref) = outs
            assert (est.tracked, est.correction, est.status) == (est_ref.tracked, est_ref.correction, est_ref.status)
            np.testing.assert_allclose(est.hand_m, est_ref.hand_m, rtol=0.0, atol=ATOL_M)
            acted += "lag" in est.correction
            assert (det is None) == (det_ref is None)
            if det is not None:
                assert (det.found, det.pixels, det.table) == (det_ref.found, det_ref.pixels, det_ref.table)
                np.testing.assert_allclose(det.position_m, det_ref.position_m, rtol=0.0, atol=ATOL_M)
    assert acted > 100  # the lag correction acted on most frames
