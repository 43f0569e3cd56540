"""An evaluation record from a real recording: a scripted episode published to a real recorder
process, read back, and every figure of the record checked against what was published."""

from __future__ import annotations

import signal
import time

import numpy as np
import pytest

from bus_schema import topics
from services.runtime.testing import ServiceProcess, wait_alive
from services.studies.evaluation.population import EpisodeDraw
from services.studies.evaluation.record import episode_record
from services.studies.evaluation.recording import read_episode_recording

pytestmark = pytest.mark.integration

HAND = np.array([1.0, -0.26, 0.30])
#: (tool x, tool speed, held by): the tool comes toward the hand at x = 1.0, slows down, the
#: receiver takes the object, and the arm retracts fast.
TRUTH = [(0.50, 0.90, "gripper"), (0.65, 0.60, "gripper"), (0.72, 0.40, "gripper"), (0.80, 0.20, "gripper"),
         (0.90, 0.10, "gripper"), (0.97, 0.00, "both"), (0.97, 0.00, "receiver"), (0.85, 0.70, "receiver"),
         (0.60, 0.90, "receiver")]
DRAW = EpisodeDraw(episode=3, height_m=1.7, weight_kg=70.0, posture="standing", behaviour="taking", receiver={},
                   hand_reach_duration_s=1.0, pull_angle_deg=0.0, object_mass_kg=0.2, mu_static=0.6, mu_kinetic=0.5,
                   ft_noise_std_n=0.03, ft_bias_std_n=0.05, sim_seed=99)


def _publish(make_node):
    node, supervisor = make_node(), make_node("supervisor")
    pub = {t: node.publisher(t) for t in (topics.SIM_TRUTH, topics.MOTION_GOAL, topics.MOTION_STATUS,
                                          topics.GRIPPER_RELEASE, topics.MOTION_STOP)}
    states, episode = supervisor.publisher(topics.SUPERVISOR_STATE), supervisor.publisher(topics.EPISODE)
    time.sleep(0.3)
    states.put(phase="idle", episode_id=0)
    start = states.put(phase="locate", episode_id=1)
    time.sleep(0.02)
    goal = pub[topics.MOTION_GOAL].put(goal_id="e1-transfer-1", kind="transfer", position_base_m=(0.9, -0.26, 0.3))
    sent = {}
    for i, (x, speed, holder) in enumerate(TRUTH):
        if holder == "receiver" and "release" not in sent:
            sent["release"] = pub[topics.GRIPPER_RELEASE].put(grip_force_n=4.0)
        pub[topics.SIM_TRUTH].put(tool_position_m=(x, -0.26, 0.30), receiver_hand_position_m=tuple(HAND),
                                  object_position_m=(x + 0.02, -0.26, 0.30), tool_speed_m_s=speed, held_by=holder,
                                  slip_m=0.002 * i)
        time.sleep(0.01)
    pub[topics.MOTION_STATUS].put(goal_id="e1-transfer-1", state="reached")
    pub[topics.MOTION_STOP].put(reason="protective stop: planner silent", protective=True)
    episode.put(episode_id=1, outcome="released", reason="released to the receiver",
                transfer_point_base_m=(0.93, -0.259, 0.31), receiver_posture="standing",
                phase_durations_s={"pick": 2.5, "reach": 1.5}, peak_grip_force_n=12.5, force_overshoot_n=1.5,
                release_to_stop_s=0.004, faults=["planner: silent"])
    return start, goal, sent["release"]


def test_the_record_holds_what_the_recording_holds(bus, make_node, tmp_path):
    profile, router = bus
    out = tmp_path / "episode.rrd"
    with ServiceProcess("services.recorder", profile, ["--output", str(out), "--no-urdf"]) as rec:
        wait_alive(router, profile, {"recorder"})
        start, goal, release = _publish(make_node)
        time.sleep(0.5)
        rec.proc.send_signal(signal.SIGTERM)
        assert rec.proc.wait(30) == 0, rec.log_text()

    r = episode_record(DRAW, read_episode_recording(out), np.array([0.90, -0.259, 0.31]), 0, 12.0)
    assert (r["outcome"], r["success"], r["dropped"], r["final_holder"]) == ("released", True, False, "receiver")
    assert r["time_to_handover_s"] == pytest.approx((release.stamp_ns - start.stamp_ns) * 1e-9, abs=1e-6)
    assert r["reach_to_release_s"] == pytest.approx((release.stamp_ns - goal.stamp_ns) * 1e-9, abs=1e-6)
    assert r["transfer_point_error_m"] == pytest.approx(0.03, abs=1e-9)
    distances = [np.linalg.norm(np.array([x, -0.26, 0.30]) - HAND) for x, _s, _h in TRUTH]
    assert r["min_tool_hand_distance_m"] == pytest.approx(min(distances))
    # Within 0.3 m of the hand: x >= 0.70; before the release 0.40 m/s (x = 0.72), after it 0.70 (x = 0.85).
    assert r["peak_speed_near_hand_before_release_m_s"] == pytest.approx(0.40)
    assert r["peak_speed_near_hand_after_release_m_s"] == pytest.approx(0.70)
    assert r["peak_speed_near_hand_m_s"] == pytest.approx(0.70)
    assert (r["peak_grip_force_n"], r["force_overshoot_n"], r["release_to_rest_s"]) == (12.5, 1.5, 0.004)
    assert r["protective_stops"] == ["protective stop: planner silent"] and r["faults"] == ["planner: silent"]
    assert r["phase_durations_s"] == {"pick": 2.5, "reach": 1.5}
    # Plan: the transfer goal was reached; reach: the hand was within 6 cm of the object while
    # the robot held it (x 0.97 + 0.02 → 1 cm); stable: 0.008 m of slip at most while carried;
    # not safe: 0.40 m/s near the hand.
    assert r["criteria"] == {"plan": True, "reach": True, "stability": True, "affordance": None, "safe": False}
