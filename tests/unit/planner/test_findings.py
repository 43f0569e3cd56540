"""The thesis's findings (§2.4.1, §2.5) as properties of the model.

The "sitting → lower" finding depends on one placement assumption (a human's shoulder leans
toward the partner by `lean_fraction_of_height`·H, default 0.04); the last test pins down what
happens without it, so that the dependence stays documented and visible.
"""

from dataclasses import replace

import numpy as np
import pytest

from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN, BodyDimensions
from services.planner.transfer_plan import DyadGeometry, plan_transfer
from services.planner.djt.settings import DJTSettings, UPPER_ARM_UNCAPPED_ANGLE_RAD
from services.planner.scene_args import EMPTY_CUP_KG, FULL_CUP_KG

A = FIGURE3_ACTOR
SIT = replace(A, posture="sitting")
ROBOT = DyadGeometry(giver_is_robot=True)


@pytest.mark.parametrize(
    "giver, receiver, geometry",
    [
        (A, A, DyadGeometry()),
        (A, SIT, DyadGeometry()),
        (ROBOT_AS_HUMAN, A, ROBOT),
        (ROBOT_AS_HUMAN, SIT, ROBOT),
    ],
)
def test_full_cup_is_handed_over_closer_to_the_giver_than_empty_cup(giver, receiver, geometry):
    empty = plan_transfer(giver, receiver, EMPTY_CUP_KG, geometry)
    full = plan_transfer(giver, receiver, FULL_CUP_KG, geometry)
    assert full.position_task_m[0] < empty.position_task_m[0] - 0.001


def test_transfer_x_decreases_monotonically_with_object_mass():
    xs = [plan_transfer(A, A, m).position_task_m[0] for m in (0.0, 0.2, 0.4, 0.8)]
    assert all(b < a for a, b in zip(xs, xs[1:]))


def test_point_is_lower_when_either_actor_sits():
    both = plan_transfer(A, A, 0.2).position_task_m[1]
    giver_sits = plan_transfer(SIT, A, 0.2).position_task_m[1]
    receiver_sits = plan_transfer(A, SIT, 0.2).position_task_m[1]
    assert giver_sits < both - 0.05
    assert receiver_sits < both - 0.05


def test_robot_giver_hands_lower_to_a_sitting_receiver():
    standing = plan_transfer(ROBOT_AS_HUMAN, A, EMPTY_CUP_KG, ROBOT).position_task_m[1]
    sitting = plan_transfer(ROBOT_AS_HUMAN, SIT, EMPTY_CUP_KG, ROBOT).position_task_m[1]
    assert sitting < standing - 0.05


def test_swapping_two_actors_mirrors_the_point_when_no_one_carries_a_load():
    tall = BodyDimensions(1.90, 1.95, 95.0)
    short = BodyDimensions(1.60, 1.58, 55.0)
    s = DJTSettings(object_load="none")
    p = plan_transfer(tall, short, 0.3, settings=s).position_task_m
    q = plan_transfer(short, tall, 0.3, settings=s).position_task_m
    assert q[0] == pytest.approx(-p[0], abs=1e-3)
    assert q[1] == pytest.approx(p[1], abs=1e-3)
    assert abs(p[0]) > 0.005  # different bodies: not trivially on the midline


def test_identical_actors_meet_in_the_middle_without_object_and_toward_giver_with_it():
    assert plan_transfer(A, A, 0.0).position_task_m[0] == pytest.approx(0.0, abs=1e-3)
    assert plan_transfer(A, A, 0.2).position_task_m[0] < -0.01


def test_swapping_identical_actors_mirrors_the_point_with_the_load_on_the_other_side():
    giver_carries = plan_transfer(A, A, 0.2, settings=DJTSettings(object_load="giver"))
    receiver_carries = plan_transfer(A, A, 0.2, settings=DJTSettings(object_load="receiver"))
    assert receiver_carries.position_task_m[0] == pytest.approx(-giver_carries.position_task_m[0], abs=1e-3)
    assert receiver_carries.position_task_m[1] == pytest.approx(giver_carries.position_task_m[1], abs=1e-3)


def test_without_lean_the_uncapped_model_fails_the_sitting_finding_on_a_reach_limit():
    """The thesis's model as written (upper arm may rise to vertical), shoulders fixed 1 m
    apart: the overlap is narrow, the optimum moves onto the sitting receiver's reach limit
    with the arm raised above its shoulder."""
    no_lean = DyadGeometry(lean_fraction_of_height=0.0)
    uncapped = DJTSettings(shoulder_angle_range_rad=(np.deg2rad(-150.0), UPPER_ARM_UNCAPPED_ANGLE_RAD))
    both = plan_transfer(A, A, 0.2, no_lean, uncapped)
    receiver_sits = plan_transfer(A, SIT, 0.2, no_lean, uncapped)
    assert receiver_sits.position_task_m[1] > both.position_task_m[1]
    assert "receiver_reach" in receiver_sits.active_constraints
    assert receiver_sits.position_task_m[1] > receiver_sits.dyad.receiver.shoulder_z_m


def test_with_the_upper_arm_cap_the_sitting_finding_holds_even_without_lean():
    """Capping the upper arm at horizontal removes the raised-arm reach-limit optimum: with no
    lean at all the sitting receiver still gets a lower point, with its upper arm at most
    horizontal (elbow not above the shoulder)."""
    no_lean = DyadGeometry(lean_fraction_of_height=0.0)
    both = plan_transfer(A, A, 0.2, no_lean)
    receiver_sits = plan_transfer(A, SIT, 0.2, no_lean)
    assert receiver_sits.position_task_m[1] < both.position_task_m[1] - 0.05
    assert receiver_sits.optimum.receiver_joint_rad[0] <= 1e-6
