"""Body dimensions from noisy skeletons of synthetic bodies of known size.

Tolerances (stated in docs/tracker.md): height ±4 cm standing (from the head's height) and
±8 cm sitting (from noisy leg segments), arm span ±8 cm, shoulder height ±3 cm, posture exact,
from 90 frames (3 s) with 50–100 mm joint jitter.
"""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import SKELETON_JOINTS
from handover_model import scene
from robot_sim.kinect.receiver import BodySize, ReceiverBody
from robot_sim.kinect.skeleton_model import SkeletonErrorModel, SkeletonErrorParams
from services.tracker.body import BodyDimensionEstimator

FLOOR = -scene.BASE_HEIGHT_ABOVE_FLOOR_M


@pytest.mark.parametrize(
    "height, posture, jitter",
    [(1.55, "standing", 0.05), (1.75, "standing", 0.10), (1.95, "standing", 0.07),
     (1.65, "sitting", 0.05), (1.85, "sitting", 0.10)],
)
def test_body_dimensions_within_tolerance(height, posture, jitter):
    body = ReceiverBody(BodySize(height, posture))
    errors = SkeletonErrorModel(SkeletonErrorParams(jitter_rms_range_m=(jitter, jitter)), np.random.default_rng(7))
    est = BodyDimensionEstimator(FLOOR, window=90)
    rng = np.random.default_rng(1)
    for k in range(90):
        hand = body.rest_hand_m + rng.normal(0, 0.05, 3)  # the hand wanders
        truth = body.joints(hand)
        arr = np.stack([truth[n] for n in SKELETON_JOINTS])
        _, noisy, _ = errors.step(k / 30.0, arr, np.array([9.0, 9.0, 9.0]))
        est.update({n: noisy[i] for i, n in enumerate(SKELETON_JOINTS)})
    dims = est.estimate()
    size = body.size
    assert dims.posture == posture
    assert dims.height_m == pytest.approx(height, abs=0.04 if posture == "standing" else 0.08)
    assert dims.arm_span_m == pytest.approx(size.arm_span_m, abs=0.08)
    assert dims.shoulder_height_m == pytest.approx(size.shoulder_height_above_floor_m, abs=0.03)
    assert dims.frames == 90


def test_missing_joints_are_ignored():
    est = BodyDimensionEstimator(FLOOR)
    assert est.update({"head": np.zeros(3)}) is False
    assert est.estimate().posture == "unknown"
