"""Mincelli corrections: lag snap inside the box, proximity hold engage/release, robot points."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model.shapes import Capsule
from services.tracker.corrections import ProximityFilter, lag_correct, robot_point_mask


def test_lag_correction_snaps_to_the_point_closest_to_the_reference_inside_the_box():
    estimate = np.array([1.0, 0.0, 0.0])
    reference = np.array([0.0, 0.0, 0.0])
    cloud = np.array(
        [
            [1.05, 0.02, 0.0],  # in the box, 1.0502 m from the reference
            [0.93, -0.05, 0.03],  # in the box, closest: 0.9318 m
            [0.80, 0.0, 0.0],  # closer still but outside the 0.1 m box
            [1.09, 0.09, -0.09],  # in the box, far
        ]
    )
    res = lag_correct(estimate, cloud, reference, box_half_size_m=0.1)
    assert res.acted and res.points_in_box == 3
    np.testing.assert_allclose(res.position_m, [0.93, -0.05, 0.03])
    # With a surface offset the result moves 2 cm further from the reference along its ray.
    res = lag_correct(estimate, cloud, reference, 0.1, surface_offset_m=0.02)
    expected = np.array([0.93, -0.05, 0.03]) * (1 + 0.02 / np.linalg.norm([0.93, -0.05, 0.03]))
    np.testing.assert_allclose(res.position_m, expected)
    # Averaging within 5 cm of the closest point: only that point and none else here.
    res = lag_correct(estimate, cloud, reference, 0.1, snap_radius_m=0.05)
    np.testing.assert_allclose(res.position_m, [0.93, -0.05, 0.03])


def test_lag_correction_does_nothing_when_no_point_is_inside_the_box():
    estimate = np.array([1.0, 0.0, 0.0])
    cloud = np.array([[0.8, 0.0, 0.0], [1.0, 0.3, 0.0], [1.0, 0.0, -0.11]])
    res = lag_correct(estimate, cloud, np.zeros(3), box_half_size_m=0.1)
    assert not res.acted
    np.testing.assert_array_equal(res.position_m, estimate)
    assert not lag_correct(estimate, np.empty((0, 3)), np.zeros(3), 0.1).acted


def test_proximity_filter_engages_under_15_cm_holds_and_releases_after():
    filt = ProximityFilter(engage_m=0.15, release_m=0.17, mode="hold")
    robot = np.array([0.0, 0.0, 0.0])
    outputs, engaged = [], []
    # The estimate walks toward the robot hand 2 cm per frame from 25 cm, then back out.
    xs = [0.25 - 0.02 * k for k in range(8)] + [0.11 + 0.02 * k for k in range(8)]
    for k, x in enumerate(xs):
        out, on = filt.update(k / 30.0, np.array([x, 0.0, 0.0]), robot)
        outputs.append(out[0])
        engaged.append(on)
    first = engaged.index(True)
    assert xs[first] < 0.15 and xs[first - 1] >= 0.15  # engages at the first frame under 15 cm
    assert outputs[first] == pytest.approx(xs[first - 1])  # holds the last estimate before
    held = [o for o, e in zip(outputs, engaged) if e]
    assert np.allclose(held, xs[first - 1])
    last = len(engaged) - 1 - engaged[::-1].index(True)
    assert xs[last + 1] > 0.17 and engaged[last + 1] is False  # releases once beyond 17 cm
    assert outputs[last + 1] == pytest.approx(xs[last + 1])
    # Unknown robot hand: never engages.
    filt.reset()
    assert filt.update(0.0, np.zeros(3), None) == (pytest.approx(np.zeros(3)), False)


def test_proximity_predict_extrapolates_with_decaying_velocity():
    filt = ProximityFilter(0.15, 0.17, mode="predict", time_constant_s=0.2)
    robot = np.array([1.0, 0.0, 0.0])
    for k in range(5):  # 0.6 m/s toward the robot, far from it
        filt.update(k * 0.1, np.array([0.5 + 0.06 * k, 0.0, 0.0]), robot)
    out, on = filt.update(0.5, np.array([0.9, 0.0, 0.0]), robot)
    assert on
    out, _ = filt.update(0.9, np.array([0.95, 0.0, 0.0]), robot)
    # Held at 0.74 m (t = 0.4 s) moving at 0.6 m/s: 0.74 + 0.6·0.2·(1 − e^(−0.5/0.2)).
    assert out[0] == pytest.approx(0.74 + 0.6 * 0.2 * (1 - np.exp(-2.5)), abs=1e-6)


def test_robot_point_mask_removes_points_within_the_inflated_capsules():
    caps = [Capsule(np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), 0.05)]
    pts = np.array([[0.5, 0.07, 0.0], [0.5, 0.09, 0.0], [1.07, 0.0, 0.0], [-0.09, 0.0, 0.0], [2.0, 0, 0]])
    mask = robot_point_mask(pts, caps, margin_m=0.03)
    assert mask.tolist() == [True, False, True, False, False]
