"""The receiver leans toward a hand target beyond its straight arm (at most 0.04·H)."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.kinect.receiver import MAX_LEAN_RATIO, BodySize, ReceiverBody


def _body(posture="sitting"):
    return ReceiverBody(BodySize(1.75, posture))


def test_a_target_within_reach_leaves_the_trunk_where_it_is():
    body = _body()
    rest = body.joints(body.rest_hand_m)
    sh = rest["right_shoulder"]
    target = sh + np.array([-0.5 * body.reach_m, 0.0, 0.1])
    j = body.joints(target)
    np.testing.assert_allclose(j["right_shoulder"], sh)
    np.testing.assert_allclose(j["torso"], rest["torso"])
    np.testing.assert_allclose(j["right_hand"], target, atol=1e-9)


def test_a_target_a_little_beyond_reach_is_reached_by_leaning_exactly_enough():
    body = _body()
    sh = body.joints(body.rest_hand_m)["right_shoulder"]
    # 5 cm beyond the straight arm, 30° above horizontal, toward the robot (−x).
    u = np.array([-np.cos(np.radians(30)), 0.0, np.sin(np.radians(30))])
    target = sh + u * (0.995 * body.reach_m + 0.05)
    j = body.joints(target)
    np.testing.assert_allclose(j["right_hand"], target, atol=1e-6)  # reached
    shift = j["right_shoulder"] - sh
    assert shift[1] == 0.0 and shift[2] == 0.0 and shift[0] < 0.0  # leaned horizontally, toward it
    # Exactly enough: from the leaned shoulder the target is at the straight arm, and the lean
    # equals the root found by a different method (bisection on the distance).
    assert abs(np.linalg.norm(target - j["right_shoulder"]) - 0.995 * body.reach_m) < 1e-9
    lo, hi = 0.0, 0.2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        far = np.linalg.norm(target - (sh + np.array([-mid, 0.0, 0.0]))) > 0.995 * body.reach_m
        lo, hi = (mid, hi) if far else (lo, mid)
    assert abs(-shift[0] - lo) < 1e-6
    assert abs(shift[0]) < MAX_LEAN_RATIO * 1.75
    # Hips and legs stay; the torso joint moves half as far as the shoulders.
    rest = body.joints(body.rest_hand_m)
    for name in ("right_hip", "left_hip", "right_knee", "left_foot"):
        np.testing.assert_allclose(j[name], rest[name])
    np.testing.assert_allclose(j["torso"] - rest["torso"], 0.5 * shift)


def test_the_lean_is_capped_at_four_percent_of_height():
    body = _body("standing")
    sh = body.joints(body.rest_hand_m)["right_shoulder"]
    target = sh + np.array([-(body.reach_m + 0.5), 0.0, 0.0])
    j = body.joints(target)
    assert abs((j["right_shoulder"] - sh)[0]) == pytest.approx(MAX_LEAN_RATIO * 1.75)
    assert np.linalg.norm(j["right_hand"] - target) > 0.3  # still out of reach
