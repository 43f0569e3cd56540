"""A still receiver and a still arm are not solved again every frame (`KinectSim`): the body's
joints and the tool's FK are kept while the hand and the joints keep their bytes, and the
frames are the same, bit for bit, as those of a simulator that solves every frame."""

from __future__ import annotations

import numpy as np

from handover_model import robots
from robot_sim.kinect.sim import KinectSim


def _frame_text(frame) -> str:
    return repr((frame.skeleton_fields, frame.truth.joints_m, frame.truth.robot_tool_m.tolist(),
                 frame.truth.right_hand_m.tolist()))


def test_still_frames_solve_once_and_equal_frames_solved_every_time(monkeypatch):
    q = np.array(robots.active().home_rad, float)
    hands = [np.array([0.55, -0.25, 0.95])] * 5 + [np.array([0.56, -0.25, 0.95])] * 3
    cached, fresh = KinectSim(seed=4), KinectSim(seed=4)
    solved = {"joints": 0, "tool": 0}
    body_joints, tool_position = cached.body.joints, cached.arm.tool_position

    def counted_joints(hand):
        solved["joints"] += 1
        return body_joints(hand)

    def counted_tool(q_rad):
        solved["tool"] += 1
        return tool_position(q_rad)

    monkeypatch.setattr(cached.body, "joints", counted_joints)
    monkeypatch.setattr(cached.arm, "tool_position", counted_tool)
    for i, hand in enumerate(hands):
        a = cached.step(i / 30.0, q.copy(), right_hand_m=hand.copy())
        fresh._joints_for = fresh._tool_for = None  # solve every frame
        b = fresh.step(i / 30.0, q.copy(), right_hand_m=hand.copy())
        assert _frame_text(a) == _frame_text(b), i
    assert solved == {"joints": 2, "tool": 1}
    frame = cached.step(1.0, q, right_hand_m=hands[-1])
    assert not frame.truth.joints_m["head"].flags.writeable  # shared between frames: read-only
