"""Minimum-jerk paths, duration rules and Ruckig moves/stops, checked against hand calculations."""

from __future__ import annotations

import numpy as np
import pytest

from services.motion.errors import TrajectoryError
from services.motion.paths import (
    JointLimits,
    JointTrajectoryPlanner,
    QuinticPath,
    min_jerk_phase,
    peak_speed_near,
    rest_to_rest_duration_s,
    zone_limited_duration_s,
)


def test_min_jerk_phase_boundaries_and_peak():
    s, ds, dds = min_jerk_phase(np.array([0.0, 1.0]))
    assert s.tolist() == [0.0, 1.0]
    assert ds.tolist() == [0.0, 0.0]
    assert dds.tolist() == [0.0, 0.0]
    tau = np.linspace(0, 1, 10001)
    _, ds, _ = min_jerk_phase(tau)
    # Peak of 30 τ²(1−τ)² is at τ = 1/2 with value 30/16 = 1.875.
    assert tau[np.argmax(ds)] == pytest.approx(0.5, abs=1e-4)
    assert ds.max() == pytest.approx(1.875, rel=1e-6)


def test_rest_to_rest_quintic_is_a_straight_line_with_bell_speed():
    p0, p1, T = np.array([0.6, -0.5, -0.1]), np.array([0.8, -0.26, 0.2]), 1.3
    path = QuinticPath(p0, p1, T)
    t = np.linspace(0.0, T, 2601)
    p, v, a = path.sample(t)
    d = p1 - p0
    # On the segment: no component perpendicular to d.
    assert np.abs(np.cross(p - p0, d)).max() < 1e-12
    assert np.allclose(p[0], p0) and np.allclose(p[-1], p1)
    assert np.abs(v[[0, -1]]).max() < 1e-12 and np.abs(a[[0, -1]]).max() < 1e-12
    speed = np.linalg.norm(v, axis=1)
    assert t[np.argmax(speed)] == pytest.approx(T / 2, abs=T / 2600)
    assert speed.max() == pytest.approx(1.875 * np.linalg.norm(d) / T, rel=1e-6)
    # Velocity is the derivative of position (independent numerical check).
    assert np.allclose(np.gradient(p, t, axis=0)[1:-1], v[1:-1], atol=1e-4)


def test_quintic_with_start_velocity_matches_all_boundary_conditions():
    v0, a0 = np.array([0.3, -0.1, 0.05]), np.array([1.0, 0.5, -2.0])
    path = QuinticPath(np.zeros(3), np.array([0.2, 0.1, 0.0]), 0.8, v0, a0)
    p, v, a = path.sample(np.array([0.0, 0.8]))
    assert np.allclose(p[0], 0) and np.allclose(v[0], v0) and np.allclose(a[0], a0)
    assert np.allclose(p[1], [0.2, 0.1, 0.0]) and np.allclose(v[1], 0) and np.allclose(a[1], 0, atol=1e-9)


def test_duration_rules():
    # explicit duration wins (if under the speed cap)
    assert rest_to_rest_duration_s(0.4, 2.0, 0.0, 1.5, 1.0, 0.3) == 2.0
    # peak speed: T = 1.875 D / v
    assert rest_to_rest_duration_s(0.4, 0.0, 0.5, 1.5, 1.0, 0.3) == pytest.approx(1.5)
    # default normalised peak V_max = 1.5 1/s: T = 1.875 / 1.5
    assert rest_to_rest_duration_s(0.4, 0.0, 0.0, 1.5, 1.0, 0.3) == pytest.approx(1.25)
    # tool speed cap 1 m/s lengthens a fast request: 1.875 * 1.0 / 1.0
    assert rest_to_rest_duration_s(1.0, 0.5, 0.0, 1.5, 1.0, 0.3) == pytest.approx(1.875)
    assert rest_to_rest_duration_s(0.001, 0.0, 0.0, 100.0, 1.0, 0.3) == 0.3
    with pytest.raises(TrajectoryError):
        QuinticPath(np.zeros(3), np.ones(3), 0.0)


def test_zone_limited_duration_meets_the_cap_exactly():
    p0, p1 = np.array([0.6, -0.5, -0.15]), np.array([0.62, -0.26, 0.12])
    hand = p1 + np.array([0.1, 0.0, 0.0])

    def make(d):
        return QuinticPath(p0, p1, d)

    t_req = 1.0
    assert peak_speed_near(make(t_req), hand, 0.3) > 0.25
    t = zone_limited_duration_s(make, t_req, hand, 0.3, 0.25)
    assert t > t_req
    # Independent check on a much finer grid: the cap holds and is nearly tight.
    path = make(t)
    times = np.linspace(0, t, 20001)
    p, v, _ = path.sample(times)
    inside = np.linalg.norm(p - hand, axis=1) < 0.3
    peak = np.linalg.norm(v[inside], axis=1).max()
    assert peak <= 0.25 * 1.002
    assert peak >= 0.25 * 0.98
    # Rest-to-rest speed scales as 1/T, so the zone peak at t_req predicts t (hand calculation).
    assert t == pytest.approx(t_req * peak_speed_near(make(t_req), hand, 0.3, 20001) / 0.25, rel=0.01)
    # A far hand changes nothing.
    assert zone_limited_duration_s(make, t_req, hand + 5.0, 0.3, 0.25) == t_req


LIMITS = JointLimits(
    lower_rad=np.full(7, -3.0), upper_rad=np.full(7, 3.0),
    velocity_rad_s=np.array([1.5, 1.5, 1.5, 1.5, 4.0, 4.0, 4.0]),
    acceleration_rad_s2=np.full(7, 3.0), jerk_rad_s3=np.full(7, 30.0),
)


def _finite_differences(traj, dt=1e-3):
    t = np.arange(0.0, traj.duration_s + dt, dt)
    states = [traj.state_at(float(x)) for x in t]
    q = np.array([s[0] for s in states])
    dq = np.array([s[1] for s in states])
    ddq = np.array([s[2] for s in states])
    return t, q, dq, ddq


def test_ruckig_move_respects_jerk_acceleration_velocity_and_arrives_at_rest():
    planner = JointTrajectoryPlanner(7)
    q0 = np.zeros(7)
    q1 = np.array([0.8, -0.5, 0.3, 1.0, -1.2, 0.4, 2.0])
    traj = planner.move(q0, np.zeros(7), np.zeros(7), q1, LIMITS)
    t, q, dq, ddq = _finite_differences(traj)
    jerk = np.diff(ddq, axis=0) / np.diff(t)[:, None]
    assert np.abs(jerk).max() <= 30.0 * 1.01
    assert np.all(np.abs(ddq) <= 3.0 + 1e-9)
    assert np.all(np.abs(dq) <= LIMITS.velocity_rad_s + 1e-9)
    assert np.allclose(q[-1], q1, atol=1e-9) and np.abs(dq[-1]).max() < 1e-9
    # A single joint: rest-to-rest time-optimal move of 2.0 rad with v=4, a=3, j=30 reaches
    # a = 3 in 0.1 s; the lower bound from the acceleration limit alone is 2*sqrt(2/3).
    assert traj.duration_s >= 2 * np.sqrt(2.0 / 3.0)
    # minimum_duration stretches the move
    slow = planner.move(q0, np.zeros(7), np.zeros(7), q1, LIMITS, minimum_duration_s=5.0)
    assert slow.duration_s == pytest.approx(5.0)


def test_ruckig_move_refuses_targets_outside_limits():
    with pytest.raises(TrajectoryError, match="outside the joint limits"):
        JointTrajectoryPlanner(7).move(np.zeros(7), np.zeros(7), np.zeros(7), np.full(7, 4.0), LIMITS)


def test_ruckig_stop_brings_velocity_to_zero_within_limits():
    stop_limits = JointLimits(LIMITS.lower_rad, LIMITS.upper_rad, LIMITS.velocity_rad_s,
                              np.full(7, 40.0), np.full(7, 4000.0))
    dq0 = np.array([1.0, -0.8, 0.5, 1.2, -0.3, 2.0, 0.0])
    traj = JointTrajectoryPlanner(7).stop(np.zeros(7), dq0, np.zeros(7), stop_limits)
    t, q, dq, ddq = _finite_differences(traj, dt=1e-4)
    assert np.abs(dq[-1]).max() < 1e-9 and np.abs(ddq[-1]).max() < 1e-9
    assert np.all(np.abs(ddq) <= 40.0 + 1e-9)
    jerk = np.diff(ddq, axis=0) / np.diff(t)[:, None]
    assert np.abs(jerk).max() <= 4000.0 * 1.01
    # Hand calculation for the fastest joint (2 rad/s): jerk ramp 0.01 s to 40 rad/s², a constant
    # segment, and a ramp down: t = v/a + a/j = 0.05 + 0.01 = 0.06 s. Joints brake independently.
    assert traj.duration_s == pytest.approx(2.0 / 40.0 + 40.0 / 4000.0, abs=1e-6)
    # Braking distance of that joint: v * t / 2 for a symmetric profile = 2 * 0.06 / 2.
    assert q[-1][5] == pytest.approx(0.06, abs=1e-4)


def test_cartesian_reach_orientation_slerp_matches_scipy():
    from scipy.spatial.transform import Rotation, Slerp

    from services.motion.paths import CartesianReach

    r0 = Rotation.from_euler("xyz", [0.3, -0.2, 1.0]).as_matrix()
    r1 = Rotation.from_euler("xyz", [3.1, 0.1, -0.5]).as_matrix()
    reach = CartesianReach(np.zeros(3), np.ones(3), r0, r1, 2.0)
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([r0, r1])))
    for t in np.linspace(0, 2.0, 9):
        s, _, _ = min_jerk_phase(t / 2.0)
        _, rot, _ = reach.pose_at(t)
        assert np.allclose(rot, slerp(float(s)).as_matrix(), atol=1e-9)
