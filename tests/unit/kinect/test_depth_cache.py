"""The simulated Kinect reuses a frame's depth only when every input that shapes the image is
unchanged, and renders anew when any of them changes."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import scene
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from robot_sim.kinect import KinectScenario, KinectSim
from robot_sim.kinect.depth import kinect_depth_mm
from robot_sim.kinect.receiver import BodySize, ReceiverBody

HOME = np.array(RIGHT_ARM_HOME_RAD)
OBJECT = np.asarray(scene.OBJECT_PICK_BASE_M, float)


@pytest.fixture()
def sim() -> KinectSim:
    # Scripted reach from t = 1 s to 1.5 s; no noise, so an unchanged image is reused whole.
    return KinectSim(seed=1, scenario=KinectScenario(hand_target_base_m=(0.75, -0.26, 0.05), reach_start_s=1.0,
                                                     reach_duration_s=0.5, depth_noise=False))


def _expected(sim: KinectSim, t_s: float, q: np.ndarray, obj: np.ndarray, hand: np.ndarray | None = None) -> bytes:
    joints = sim.body.joints(sim.true_hand(t_s) if hand is None else hand)
    return kinect_depth_mm(sim.reference_depth_m(joints, q, obj), None).astype("<u2").tobytes()


def test_same_inputs_reuse_the_frame_and_any_change_renders_anew(sim):
    t = 0.0
    first = sim.step(t, HOME, object_position_m=OBJECT).depth_fields["depth_mm"]  # read: rendered now
    cast = sim.depth.cast

    def step(q, obj, hand=None):
        nonlocal t
        t += 1.0 / 30.0
        return sim.step(t, q, object_position_m=obj, right_hand_m=hand).depth_fields["depth_mm"]

    again = step(HOME, OBJECT.copy())  # equal values in new arrays
    assert again is first  # the same bytes object: nothing rendered
    assert not sim.depth.changed and sim.depth.cast == cast
    previous = again
    hand = sim.body.rest_hand_m + np.array([-0.25, 0.0, 0.2])
    changes = [
        ("a joint angle", HOME + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.08, 0.0]), OBJECT, None),
        ("the object", HOME + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.08, 0.0]), OBJECT + [0.0, 0.03, 0.0], None),
        ("the receiver's hand", HOME + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.08, 0.0]), OBJECT + [0.0, 0.03, 0.0],
         hand),
    ]
    for what, q, obj, hand_m in changes:
        cast = sim.depth.cast
        got = step(q, obj, hand_m)
        assert sim.depth.changed, what
        assert got != previous, what
        assert got == _expected(sim, t, q, obj, hand_m), what
        assert 1 <= sim.depth.cast - cast <= 8, what  # only the primitives that moved were cast
        assert step(q, obj, hand_m) is got and not sim.depth.changed, what  # then reused
        previous = got


def test_the_scripted_reach_animates_the_body_over_time_only_while_it_moves(sim):
    before = [sim.step(t, HOME).depth_fields["depth_mm"] for t in (0.0, 0.5, 0.9)]
    assert before[0] is before[1] is before[2]  # before the reach: time passes, the body stays
    during = []
    for t in (1.1, 1.2, 1.3):
        during.append(sim.step(t, HOME).depth_fields["depth_mm"])
        assert sim.depth.changed
        assert during[-1] == _expected(sim, t, HOME, OBJECT)
    assert len(set(during)) == 3 and before[0] not in during
    after = [sim.step(t, HOME).depth_fields["depth_mm"] for t in (1.6, 1.7)]
    assert after[0] is after[1] and after[0] == _expected(sim, 1.7, HOME, OBJECT)


def test_the_receivers_legs_never_move_so_they_are_static():
    body = ReceiverBody(BodySize(1.8, "sitting"))
    static = body.static_capsules()
    shoulder = body.joints(body.rest_hand_m)["right_shoulder"]
    rng = np.random.default_rng(0)
    for _ in range(20):
        joints = body.joints(shoulder + rng.uniform(-1.2, 1.2, 3))  # far targets: the trunk leans
        legs = body.capsules(joints)[-len(static):]
        for leg, fixed in zip(legs, static, strict=True):
            assert np.array_equal(leg.a_m, fixed.a_m) and np.array_equal(leg.b_m, fixed.b_m)
            assert leg.radius_m == fixed.radius_m
        assert len(body.moving_capsules(joints)) + len(static) == len(body.capsules(joints))
