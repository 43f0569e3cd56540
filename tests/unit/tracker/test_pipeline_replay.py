"""Tracker pipeline states (empty/stale skeletons, missing inputs) and replay files."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema import topics as T
from bus_schema.messages import Skeleton
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import ArmGeometry
from services.tracker.config import TrackerConfig, config_from_dict
from services.tracker.core import SkeletonFrame, TrackerPipeline, skeleton_frame_from_message
from services.tracker.errors import ReplayFileError, TrackerConfigError
from services.tracker.replay import ReplayWriter, read_replay


@pytest.fixture(scope="module")
def arm():
    return ArmGeometry()


def test_empty_and_stale_skeletons_give_a_clear_untracked_state(arm):
    pipe = TrackerPipeline(TrackerConfig(skeleton_timeout_s=0.5, lag_min_speed_m_s=0.0, proximity_filter=True), arm)
    assert not pipe.human_state(0.0).tracked
    est = pipe.on_skeleton(skeleton_frame_from_message(Skeleton(seq=0, stamp_ns=0, source="t", tracked=True), 0.0))
    assert not est.tracked and "no person" in est.status
    hand = np.array([0.8, -0.26, 0.0])
    est = pipe.on_skeleton(SkeletonFrame(True, {"right_hand": hand}, 1.0))
    assert est.tracked and est.correction == "none"  # no depth, no joint state: raw hand
    np.testing.assert_allclose(est.hand_m, hand)
    assert "no fresh depth" in est.status and "no fresh joint state" in est.status
    assert pipe.human_state(1.2).tracked
    stale = pipe.human_state(1.6)
    assert not stale.tracked and "stale" in stale.status and stale.frame_age_s == pytest.approx(0.6)


def test_proximity_hold_engages_in_the_pipeline_near_the_robot_hand(arm):
    pipe = TrackerPipeline(TrackerConfig(lag_correction=False, proximity_filter=True), arm)
    q = np.array(RIGHT_ARM_HOME_RAD)
    tool = arm.tool_position(q)
    pipe.on_joint_state(q, 0.0)
    far = tool + np.array([0.30, 0.0, 0.0])
    near = tool + np.array([0.10, 0.0, 0.0])
    assert pipe.on_skeleton(SkeletonFrame(True, {"right_hand": far}, 0.0)).correction == "none"
    est = pipe.on_skeleton(SkeletonFrame(True, {"right_hand": near}, 0.033))
    assert est.correction == "proximity_hold"
    np.testing.assert_allclose(est.hand_m, far)
    np.testing.assert_allclose(est.hand_raw_m, near)


def test_bad_config_is_one_clear_error():
    with pytest.raises(TrackerConfigError, match="proximity_release_m"):
        config_from_dict({"proximity_engage_m": 0.2, "proximity_release_m": 0.1})
    with pytest.raises(TrackerConfigError, match="unknown|Object contains unknown field"):
        config_from_dict({"no_such_key": 1})


def test_replay_round_trip_and_corruption(tmp_path):
    path = tmp_path / "r.trk"
    msg = Skeleton(seq=3, stamp_ns=5, source="sim", tracked=False)
    with ReplayWriter(path) as w:
        w.write(0.5, T.SKELETON, msg)
        w.write(0.6, T.SKELETON, msg)
    items = list(read_replay(path))
    assert [i.t_s for i in items] == [0.5, 0.6] and items[0].msg == msg and items[0].topic is T.SKELETON
    data = path.read_bytes()
    (tmp_path / "cut.trk").write_bytes(data[:-3])
    with pytest.raises(ReplayFileError, match="truncated"):
        list(read_replay(tmp_path / "cut.trk"))
    (tmp_path / "bad.trk").write_bytes(b"nonsense")
    with pytest.raises(ReplayFileError, match="not a tracker replay file"):
        list(read_replay(tmp_path / "bad.trk"))
    with pytest.raises(ReplayFileError, match="cannot open"):
        list(read_replay(tmp_path / "missing.trk"))
