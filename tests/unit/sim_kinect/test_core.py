"""Simulated Kinect service: joint-state mapping, scene input, truth fields, config and CLI
errors (the frame thread's pacing is `RateLoop`'s, tests/unit/runtime/test_loop_and_logs.py)."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from robot_sim.kinect.receiver import BodySize, ReceiverBody
from services.sim_kinect.cli import main
from services.sim_kinect.config import KinectConfig, parse_config
from services.sim_kinect.core import TruthGate, arm_posture_rad, make_kinect_sim, scene_input, truth_fields
from services.sim_kinect.errors import KinectConfigError

HOME = np.array(RIGHT_ARM_HOME_RAD)


def test_arm_posture_is_mapped_by_name_whatever_the_order():
    order = [3, 0, 6, 1, 5, 2, 4]
    names = ["head_pan"] + [RIGHT_ARM_JOINTS[i] for i in order]
    values = [9.0] + [float(HOME[i]) + 0.01 * i for i in order]
    q = arm_posture_rad(names, values)
    np.testing.assert_allclose(q, HOME + 0.01 * np.arange(7))


@pytest.mark.parametrize("names, values", [
    (list(RIGHT_ARM_JOINTS[:6]), list(RIGHT_ARM_HOME_RAD[:6])),           # a joint missing
    (list(RIGHT_ARM_JOINTS), list(RIGHT_ARM_HOME_RAD[:6])),               # lengths differ
    (list(RIGHT_ARM_JOINTS), [float("nan")] + list(RIGHT_ARM_HOME_RAD[1:])),  # not finite
])
def test_unusable_joint_states_give_no_posture(names, values):
    assert arm_posture_rad(names, values) is None


def test_scene_input_only_in_the_handover_scene():
    hand, obj = (0.9, -0.2, 0.1), (0.6, -0.26, 0.05)
    follow = scene_input("handover", hand, obj)
    np.testing.assert_array_equal(follow.right_hand_m, hand)
    np.testing.assert_array_equal(follow.object_position_m, obj)
    assert scene_input("none", hand, obj).right_hand_m is None
    assert scene_input("handover", None, None).right_hand_m is None  # no sim/truth yet
    assert scene_input("handover", (float("inf"), 0.0, 0.0), obj).object_position_m is None


def test_truth_fields_are_the_rendered_bodys_hand_and_torso_and_fit_the_bus():
    sim = make_kinect_sim(KinectConfig(posture="sitting", height_m=1.6))
    body = ReceiverBody(BodySize(1.6, "sitting"))
    wanted = body.joints(body.rest_hand_m)["right_shoulder"] + np.array([-0.4, 0.0, -0.1])
    frame = sim.step(0.0, HOME, right_hand_m=wanted)
    fields = truth_fields(frame)
    np.testing.assert_allclose(fields["hand_position_m"], body.joints(wanted)["right_hand"], atol=1e-9)
    np.testing.assert_allclose(fields["torso_position_m"], body.joints(wanted)["torso"], atol=1e-9)
    msg = topics.KINECT_TRUTH.type(seq=0, stamp_ns=0, source="kinect", **fields)
    from bus_schema import decode, encode_for

    assert decode(topics.KINECT_TRUTH, encode_for(topics.KINECT_TRUTH, msg)) == msg


def test_a_still_body_truth_goes_out_ten_times_a_second_and_a_moved_one_at_once():
    sim = make_kinect_sim(KinectConfig())
    body = ReceiverBody(BodySize(1.75, "standing"))
    hand = body.rest_hand_m
    gate = TruthGate()
    # Frames 33.5 ms apart (30 Hz, a little late) for one second, the body still: frames
    # 0, 3, 6, ... (every 0.1 s) go out.
    frame = sim.step(0.0, HOME, right_hand_m=hand)
    sent = [k for k in range(30) if gate.due(frame, k * 0.0335) is not None]
    assert sent == list(range(0, 30, 3))
    # The hand moved by 1 mm: the next frame goes out, with the new hand.
    moved = sim.step(1.0, HOME, right_hand_m=hand + np.array([0.0, 0.0, 1e-3]))
    fields = gate.due(moved, 1.0 + 1 / 30.0)
    assert fields is not None
    np.testing.assert_allclose(fields["hand_position_m"], truth_fields(moved)["hand_position_m"])
    assert gate.due(moved, 1.0 + 2 / 30.0) is None


@pytest.mark.parametrize("table, key", [
    ({"rate_hz": 0.0}, "rate_hz"),
    ({"height_m": 2.5}, "height_m"),
    ({"posture": "lying"}, "posture"),
    ({"scene": "transfer"}, "scene"),
    ({"hand_target_base_m": [0.5, 0.1]}, "hand_target_base_m"),
    ({"kinect_rate": 30}, "kinect_rate"),
])
def test_bad_config_names_the_key(table, key):
    with pytest.raises(KinectConfigError, match=key):
        parse_config(table)


def test_cli_bad_input_is_one_line_and_exit_2(capsys):
    assert main(["--height-m", "3.0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "height_m" in err[0]
    with pytest.raises(SystemExit) as exc:
        main(["--scene", "nowhere"])
    assert exc.value.code == 2


def test_truth_vectors_are_bounded_as_numpys_nan_to_num_then_clip():
    from services.sim_kinect.core import POSITION_BOUND_M, _vec

    for v in ([0.1, -2.5, 3.0], [np.nan, np.inf, -np.inf], [1e300, -1e300, -0.0], [100.0, -100.0, 99.9999]):
        a = np.asarray(v, float)
        expected = np.clip(np.nan_to_num(a), -POSITION_BOUND_M, POSITION_BOUND_M).tolist()
        got = _vec(a)
        assert [repr(x) for x in got] == [repr(x) for x in expected], (v, got, expected)
        assert all(type(x) is float for x in got)
