"""Anthropometrics: numbers against hand calculations from the named tables."""

import math

import pytest

from services.planner.anthropometrics import BodyDimensions, planar_arm, shoulder_height_m
from services.planner.errors import PlannerError


def test_link_lengths_masses_and_coms_match_the_tables_by_hand():
    body = BodyDimensions(height_m=1.80, arm_span_m=1.85, weight_kg=80.0)
    arm = planar_arm(body, grasp_fraction_of_hand=0.5)
    # Drillis & Contini chain spans 0.259 + 2*(0.186+0.146+0.108) = 1.139 H; scaled to L.
    unit = 1.85 / 1.139
    assert arm.upper_arm_m == pytest.approx(0.186 * unit, rel=1e-12)
    assert arm.forearm_to_grasp_m == pytest.approx((0.146 + 0.5 * 0.108) * unit, rel=1e-12)
    # Dempster via Winter Table 4.1.
    assert arm.upper_arm_mass_kg == pytest.approx(0.028 * 80.0)
    assert arm.forearm_hand_mass_kg == pytest.approx(0.022 * 80.0)
    assert arm.upper_arm_com_m == pytest.approx(0.436 * 0.186 * unit)
    assert arm.forearm_hand_com_m == pytest.approx(0.682 * 0.146 * unit)
    assert arm.shoulder_height_m == pytest.approx(0.818 * 1.80)


def test_arm_span_sets_link_lengths_and_height_sets_shoulder_height():
    short = planar_arm(BodyDimensions(1.80, 1.70, 80.0))
    long = planar_arm(BodyDimensions(1.80, 1.95, 80.0))
    assert long.reach_m / short.reach_m == pytest.approx(1.95 / 1.70)
    assert long.shoulder_height_m == short.shoulder_height_m
    tall = planar_arm(BodyDimensions(1.90, 1.95, 80.0))
    assert tall.reach_m == pytest.approx(long.reach_m)
    assert tall.shoulder_height_m - long.shoulder_height_m == pytest.approx(0.818 * 0.10)


def test_sitting_shoulder_is_seat_plus_pheasant_fraction():
    body = BodyDimensions(1.70, 1.70, 65.0, posture="sitting", seat_height_m=0.50)
    assert shoulder_height_m(body) == pytest.approx(0.50 + 0.34 * 1.70)
    standing = BodyDimensions(1.70, 1.70, 65.0)
    assert shoulder_height_m(body) < shoulder_height_m(standing)


def test_measured_shoulder_height_overrides_the_estimate():
    arm = planar_arm(BodyDimensions(1.70, 1.70, 65.0), shoulder_height_override_m=1.30)
    assert arm.shoulder_height_m == 1.30


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(height_m=1.75, arm_span_m=0.50, weight_kg=70.0), "arm span"),
        (dict(height_m=1.75, arm_span_m=1.75, weight_kg=-5.0), "weight"),
        (dict(height_m=175.0, arm_span_m=175.0, weight_kg=70.0), "height"),
        (dict(height_m=math.nan, arm_span_m=1.75, weight_kg=70.0), "height"),
        (dict(height_m=1.75, arm_span_m=1.75, weight_kg=70.0, posture="lying"), "posture"),
        (dict(height_m=1.75, arm_span_m=1.75, weight_kg=70.0, posture="sitting", seat_height_m=0.0),
         "seat height"),
    ],
)
def test_impossible_bodies_are_refused_with_a_clear_message(kwargs, words):
    with pytest.raises(PlannerError, match=words):
        BodyDimensions(**kwargs)


def test_grasp_fraction_outside_the_hand_is_refused():
    with pytest.raises(PlannerError, match="grasp fraction"):
        planar_arm(BodyDimensions(1.75, 1.75, 70.0), grasp_fraction_of_hand=1.5)
