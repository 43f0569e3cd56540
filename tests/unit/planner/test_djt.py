"""DJT model: IK, torques, feasibility, optimum — checked by independent computations."""

import numpy as np
import pytest

from services.planner.anthropometrics import FIGURE3_ACTOR, BodyDimensions, PlanarArm, planar_arm
from services.planner.djt.arms import (
    Actor,
    forward_kinematics,
    gravity_torques,
    inverse_kinematics,
    object_jacobian_torques,
)
from services.planner.djt.cost import djt_cost, search_bounds
from services.planner.djt.optimum import optimise
from services.planner.djt.settings import DJTSettings
from services.planner.errors import PlannerError
from services.planner.transfer_plan import DyadGeometry, build_dyad

G = 9.80665
ARM = PlanarArm(
    upper_arm_m=0.30,
    forearm_to_grasp_m=0.35,
    upper_arm_mass_kg=2.0,
    forearm_hand_mass_kg=1.5,
    upper_arm_com_m=0.13,
    forearm_hand_com_m=0.16,
    shoulder_height_m=1.5,
)


@pytest.mark.parametrize("facing", [1, -1])
def test_ik_round_trip_hits_the_point_on_the_elbow_down_branch(facing):
    actor = Actor(ARM, shoulder_x_m=-0.2 * facing, shoulder_z_m=0.8, facing=facing)
    rng = np.random.default_rng(1)
    r = rng.uniform(0.06, 0.649, 500)
    a = rng.uniform(-np.pi, np.pi, 500)
    x = actor.shoulder_x_m + r * np.cos(a)
    z = actor.shoulder_z_m + r * np.sin(a)
    q1, q2, ok = inverse_kinematics(actor, x, z)
    assert ok.all()
    p = forward_kinematics(actor, q1, q2)
    np.testing.assert_allclose(p[:, 0], x, atol=1e-9)
    np.testing.assert_allclose(p[:, 1], z, atol=1e-9)
    assert (q2 >= 0).all()
    # Elbow below the shoulder→hand line in the actor's own frame (cross product < 0).
    u_hand = facing * (x - actor.shoulder_x_m)
    w_hand = z - actor.shoulder_z_m
    u_elbow, w_elbow = ARM.upper_arm_m * np.cos(q1), ARM.upper_arm_m * np.sin(q1)
    cross = u_hand * w_elbow - w_hand * u_elbow
    bent = q2 > 1e-6
    assert (cross[bent] < 0).all()


def test_ik_reports_points_out_of_reach():
    actor = Actor(ARM, 0.0, 0.0, 1)
    _, _, ok = inverse_kinematics(actor, np.array([0.70, 0.01, 0.3]), np.array([0.0, 0.0, 0.0]))
    assert ok.tolist() == [False, False, True]  # beyond l1+l2; inside |l1−l2|; fine


def test_torques_match_hand_computation_in_two_postures():
    m_o = 0.5
    # Arm straight out horizontally: every lever arm is the full horizontal distance.
    ts, te = gravity_torques(ARM, 0.0, 0.0, m_o, G)
    assert ts == pytest.approx(G * (2.0 * 0.13 + 1.5 * (0.30 + 0.16) + m_o * 0.65))
    assert te == pytest.approx(G * (1.5 * 0.16 + m_o * 0.35))
    # Upper arm hanging down, forearm horizontal: the upper arm has no lever arm.
    ts, te = gravity_torques(ARM, -np.pi / 2, np.pi / 2, m_o, G)
    assert ts == pytest.approx(G * (1.5 * 0.16 + m_o * 0.35))
    assert te == pytest.approx(ts)
    # Arm hanging straight down: no torque.
    ts, te = gravity_torques(ARM, -np.pi / 2, 0.0, m_o, G)
    assert abs(ts) < 1e-12 and abs(te) < 1e-12


def test_torques_are_the_gradient_of_the_potential_energy():
    """τ = ∂V/∂q, computed here by central differences of V = Σ m g z."""
    m_o = 0.3

    def potential(q):
        q1, q2 = q
        z1 = ARM.upper_arm_com_m * np.sin(q1)
        ze = ARM.upper_arm_m * np.sin(q1)
        z2 = ze + ARM.forearm_hand_com_m * np.sin(q1 + q2)
        zh = ze + ARM.forearm_to_grasp_m * np.sin(q1 + q2)
        return G * (ARM.upper_arm_mass_kg * z1 + ARM.forearm_hand_mass_kg * z2 + m_o * zh)

    for q in ([0.3, 1.1], [-1.2, 0.4], [0.9, 2.0]):
        h = 1e-6
        grad = [
            (potential(np.add(q, d)) - potential(np.subtract(q, d))) / (2 * h)
            for d in ([h, 0.0], [0.0, h])
        ]
        ts, te = gravity_torques(ARM, q[0], q[1], m_o, G)
        assert ts == pytest.approx(grad[0], rel=1e-6)
        assert te == pytest.approx(grad[1], rel=1e-6)


def test_object_term_equals_eq_2_3_jacobian_transpose():
    for q1, q2 in ((0.2, 0.9), (-0.8, 1.4)):
        with_obj = np.array(gravity_torques(ARM, q1, q2, 0.4, G))
        without = np.array(gravity_torques(ARM, q1, q2, 0.0, G))
        np.testing.assert_allclose(with_obj - without, object_jacobian_torques(ARM, q1, q2, 0.4, G))


def test_unreachable_and_below_table_points_are_excluded():
    dyad = build_dyad(FIGURE3_ACTOR, FIGURE3_ACTOR, DyadGeometry())
    s = DJTSettings()
    g, r = dyad.giver, dyad.receiver
    x = np.array([
        g.shoulder_x_m - 0.05,               # giver can, receiver cannot
        0.0,                                  # both can (at shoulder height −0.3)
        0.0,                                  # below the table top
        0.0,                                  # far above both
    ])
    z = np.array([g.shoulder_z_m, g.shoulder_z_m - 0.3, -0.05, 2.0])
    cost, feasible = djt_cost(dyad, x, z, 0.2, s)
    assert feasible.tolist() == [False, True, False, False]
    assert np.isinf(cost[[0, 2, 3]]).all() and np.isfinite(cost[1])
    opt, cmap = optimise(dyad, 0.2, s)
    px, pz = opt.position_task_m
    for actor in (g, r):
        assert np.hypot(px - actor.shoulder_x_m, pz - actor.shoulder_z_m) <= actor.arm.reach_m + 1e-9
    assert pz >= 0.0
    assert not cmap.feasible.all() and cmap.feasible.any()


def test_a_raised_table_floor_becomes_an_active_constraint():
    dyad = build_dyad(FIGURE3_ACTOR, FIGURE3_ACTOR, DyadGeometry())
    opt, _ = optimise(dyad, 0.2, DJTSettings(min_height_above_table_m=0.65))
    assert opt.position_task_m[1] == pytest.approx(0.65, abs=1e-3)
    assert "table" in opt.active_constraints


def test_actors_too_far_apart_are_refused():
    geometry = DyadGeometry(giver_shoulder_x_task_m=-1.5, receiver_shoulder_x_task_m=1.5)
    dyad = build_dyad(FIGURE3_ACTOR, FIGURE3_ACTOR, geometry)
    with pytest.raises(PlannerError, match="do not overlap"):
        search_bounds(dyad, DJTSettings())


def test_optimum_agrees_with_a_fine_brute_force_search():
    giver = BodyDimensions(1.80, 1.84, 90.0)
    receiver = BodyDimensions(1.62, 1.60, 55.0)
    dyad = build_dyad(giver, receiver, DyadGeometry())
    s = DJTSettings()
    opt, _ = optimise(dyad, 0.3, s)
    xs = np.arange(-0.3, 0.3, 0.001)
    zs = np.arange(0.0, 1.0, 0.001)
    xx, zz = np.meshgrid(xs, zs)
    cost, _ = djt_cost(dyad, xx, zz, 0.3, s)
    k = np.argmin(cost)
    brute = np.array([xx.flat[k], zz.flat[k]])
    assert np.hypot(*(np.array(opt.position_task_m) - brute)) < 0.003
    assert opt.cost <= cost.flat[k] + 1e-6
    assert opt.cost <= opt.grid_cost


def test_planar_arm_of_figure3_actor_reaches_across_half_the_table():
    arm = planar_arm(FIGURE3_ACTOR)
    assert 0.6 < arm.reach_m < 0.7
