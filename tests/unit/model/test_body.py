"""One anthropometric table (`handover_model.body`) for the planner, the simulated receiver
and the tracker: the three read the same proportions."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import body
from robot_sim.kinect import receiver
from services.planner.anthropometrics import BodyDimensions, planar_arm


@pytest.mark.parametrize("span_m", [1.5, 1.75, 2.0])
def test_the_scaled_upper_limb_spans_the_arm_span(span_m):
    limb = body.upper_limb_m(span_m)
    assert 2.0 * (limb.shoulder_half_width_m + limb.upper_arm_m + limb.forearm_m + limb.hand_m) == pytest.approx(span_m)
    # Drillis & Contini's proportions are kept: upper arm / forearm = 0.186 / 0.146.
    assert limb.upper_arm_m / limb.forearm_m == pytest.approx(0.186 / 0.146)


def test_the_simulated_receiver_has_the_average_span_and_the_planners_arm():
    height_m = 1.8
    size = receiver.BodySize(height_m=height_m)
    assert size.arm_span_m == pytest.approx(height_m)
    arm = planar_arm(BodyDimensions(height_m, size.arm_span_m, 75.0), grasp_fraction_of_hand=0.5)
    assert size.upper_arm_m == pytest.approx(arm.upper_arm_m)
    # The receiver's forearm ends at the hand joint (the palm's centre): the planner's grasp
    # point halfway along the hand.
    assert size.forearm_m == pytest.approx(arm.forearm_to_grasp_m)
    assert size.shoulder_height_above_floor_m == pytest.approx(body.SHOULDER_HEIGHT_FRACTION * height_m)


def test_the_receivers_skeleton_measures_the_tables_segments():
    height_m = 1.7
    joints = receiver.ReceiverBody(receiver.BodySize(height_m=height_m)).joints(np.array([0.9, -0.4, 0.2]))
    shoulders_m = np.linalg.norm(joints["left_shoulder"] - joints["right_shoulder"])
    upper_arm_m = np.linalg.norm(joints["right_elbow"] - joints["right_shoulder"])
    limb = body.upper_limb_m(height_m)
    assert shoulders_m == pytest.approx(2.0 * limb.shoulder_half_width_m)
    assert upper_arm_m == pytest.approx(limb.upper_arm_m)
