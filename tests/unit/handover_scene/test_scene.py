"""The whole simulated handover scene, driven by a scripted tool path (no bus)."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.contact.config import ContactSimError
from robot_sim.handover_scene import HandoverScene, SceneParams

DT = 0.01
TRANSFER_M = np.array([0.45, -0.259, 0.285])


def pick_and_present(scene: HandoverScene, grip_n: float = 10.0, target: np.ndarray = TRANSFER_M):
    """Close at the object, lift 15 cm, then a 1.8 s minimum-jerk reach to `target`."""
    start = scene.object_m.copy()
    outs = [scene.step(DT, start, 0.0, grip_n) for _ in range(20)]
    lift = start + np.array([0.0, 0.0, 0.15])
    for i in range(100):
        outs.append(scene.step(DT, start + (lift - start) * (i + 1) / 100, 0.15, grip_n))
    for i in range(180):
        s = (i + 1) / 180
        s = 10 * s**3 - 15 * s**4 + 6 * s**5
        outs.append(scene.step(DT, lift + (target - lift) * s, 0.3, grip_n))
    return outs


def test_object_waits_on_the_table_until_the_fingers_close_at_it():
    scene = HandoverScene(SceneParams())
    start = scene.object_m.copy()
    # Near but open: nothing happens; far but closed: nothing happens.
    out = scene.step(DT, start, 0.0, 0.0)
    assert out.object_phase == "on_table" and out.held_by == "table" and not out.optical_valid
    assert out.wrist_force_n == (0.0, 0.0)
    out = scene.step(DT, start + np.array([0.0, 0.0, 0.10]), 0.0, 10.0)
    assert out.object_phase == "on_table"
    # Moving fast at the object: the pick waits for the tool to be at rest.
    out = scene.step(DT, start, 0.5, 10.0)
    assert out.object_phase == "on_table"
    out = scene.step(DT, start, 0.0, 10.0)
    assert out.object_phase == "in_gripper" and out.held_by == "gripper"
    for _ in range(20):
        out = scene.step(DT, start, 0.0, 10.0)
    # The F/T sensor now carries the weight: 0.2 kg · 9.81 = 1.96 N along y (down), plus noise.
    assert out.wrist_force_n[1] == pytest.approx(0.2 * 9.81, abs=0.3)


def test_receiver_reaches_only_when_the_object_is_presented_then_takes_it():
    scene = HandoverScene(SceneParams(behaviour="taking", seed=1))
    outs = pick_and_present(scene)
    phases = [o.receiver_phase for o in outs]
    assert phases[:120] == ["resting"] * 120  # not during the pick and the lift
    assert "reaching" in phases
    for _ in range(300):  # the arm rests at the transfer point
        out = scene.step(DT, TRANSFER_M, 0.0, 10.0)
        if out.receiver_phase == "contact":
            break
    assert out.receiver_phase == "contact"
    # An open gripper lets the receiver take it.
    for _ in range(200):
        out = scene.step(DT, TRANSFER_M, 0.0, 0.0)
    assert out.object_phase == "with_receiver" and out.held_by == "receiver" and not out.dropped
    # The object is in the receiver's hand, which pulled it toward the receiver (+x).
    assert np.linalg.norm(out.object_position_m - out.receiver_hand_m) < 0.01
    assert out.object_position_m[0] > TRANSFER_M[0] + 0.1


def test_a_retracting_arm_does_not_drag_the_receivers_object_along():
    scene = HandoverScene(SceneParams(behaviour="taking", seed=2))
    pick_and_present(scene)
    for _ in range(400):
        out = scene.step(DT, TRANSFER_M, 0.0, 0.0)
    held = out.object_position_m.copy()
    for i in range(100):
        out = scene.step(DT, TRANSFER_M + np.array([-0.3, -0.3, -0.2]) * (i + 1) / 100, 0.5, 0.0)
    assert out.held_by == "receiver"
    assert np.linalg.norm(out.object_position_m - held) < 0.01


def test_an_absent_receiver_never_reaches_and_the_object_stays_in_the_gripper():
    scene = HandoverScene(SceneParams(behaviour="absent"))
    pick_and_present(scene)
    for _ in range(300):
        out = scene.step(DT, TRANSFER_M, 0.0, 10.0)
    assert out.receiver_phase == "resting" and out.held_by == "gripper"


def test_a_point_beyond_the_receivers_arm_is_never_reached():
    far = np.array([0.15, -0.259, 0.285])  # 0.9 m from the receiving shoulder
    scene = HandoverScene(SceneParams(behaviour="taking"))
    pick_and_present(scene, target=far)
    for _ in range(300):
        out = scene.step(DT, far, 0.0, 10.0)
    assert out.receiver_phase != "contact" and out.held_by == "gripper"


def test_reset_puts_the_object_back_and_the_hand_at_rest():
    scene = HandoverScene(SceneParams())
    rest = scene.hand_m.copy()
    pick_and_present(scene)
    scene.reset()
    out = scene.step(DT, TRANSFER_M, 0.0, 10.0)
    assert out.object_phase == "on_table" and np.allclose(out.receiver_hand_m, rest)
    assert np.allclose(out.object_position_m, SceneParams().object_start_base_m)


def test_sitting_receiver_rests_its_hand_lower():
    standing = HandoverScene(SceneParams(posture="standing")).hand_m
    sitting = HandoverScene(SceneParams(posture="sitting")).hand_m
    assert sitting[2] < standing[2]


def test_bad_receiver_parameters_fail_at_construction():
    with pytest.raises(ContactSimError):
        HandoverScene(SceneParams(behaviour="juggling"))
    with pytest.raises(ContactSimError):
        HandoverScene(SceneParams(receiver={"no_such_parameter": 1.0}))


def test_a_soft_dropping_receiver_never_gets_the_object_from_a_firm_grip():
    scene = HandoverScene(SceneParams(behaviour="dropping", seed=4))
    pick_and_present(scene)
    outs = [scene.step(DT, TRANSFER_M, 0.0, 10.0) for _ in range(600)]
    assert any(o.receiver_phase == "contact" for o in outs)
    assert max(abs(o.receiver_pull_n) for o in outs) <= 3.5  # the thesis's soft pull (≈ 2–3 N)
    assert not any(o.dropped for o in outs) and outs[-1].held_by == "gripper"
