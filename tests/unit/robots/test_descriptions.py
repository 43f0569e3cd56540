"""The robot descriptions: what a profile may say, how the arm is placed, what each arm reaches."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import robots, scene
from handover_model.robots import BUILTIN, ROBOT_ENV, RobotDescriptionError, describe, from_profile
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD, RIGHT_ARM_JOINTS
from services.motion.config import MotionConfig
from services.motion.ik import UPRIGHT_ROTATION, ArmIk

#: Transfer points the planner gives each arm for the default receiver (1.75 m, standing and
#: sitting; base frame, m), from `handover-up --robot NAME` runs, seeds 1-3.
TYPICAL_TRANSFER_M = {
    "baxter": [(0.450, -0.259, 0.294), (0.410, -0.259, 0.189)],
    "panda": [(0.495, -0.259, 0.245), (0.495, -0.259, 0.089)],
    "ur5": [(0.482, -0.259, 0.236), (0.495, -0.259, 0.089)],
    "so_arm101": [(0.662, -0.259, 0.015), (0.706, -0.259, 0.045), (0.655, -0.259, -0.212)],
}


def test_baxter_is_the_default_and_keeps_todays_numbers():
    arm = from_profile({}, environ={})
    assert arm is BUILTIN["baxter"]
    assert arm.joints == RIGHT_ARM_JOINTS and arm.home_rad == RIGHT_ARM_HOME_RAD
    assert arm.tool_frame == "right_gripper" and not arm.placed and arm.tool_parent is None
    assert arm.object_pick_base_m == tuple(float(v) for v in scene.OBJECT_PICK_BASE_M)
    g = arm.gripper
    assert (g.force_rate_n_s, g.loop_rate_hz, g.force_max_n, g.force_min_n) == (50.0, 25.0, 140.0, 0.0)
    # The motion service's defaults are Baxter's: the description reproduces them.
    assert MotionConfig.from_dict({}, arm) == MotionConfig()


def test_a_profile_names_the_model_and_overrides_values():
    arm = from_profile({"robot": {"model": "panda", "base_xyz_m": [0.1, -0.3, -0.23],
                                  "gripper": {"force_max_n": 140.0}}}, environ={})
    assert arm.name == "panda" and arm.base_xyz_m == (0.1, -0.3, -0.23)
    assert arm.gripper.force_max_n == 140.0 and arm.gripper.name == "Franka Hand"  # the rest kept


def test_the_environment_replaces_the_model_and_drops_the_other_models_overrides():
    doc = {"robot": {"model": "panda", "base_xyz_m": [0.1, -0.3, -0.23]}}
    assert from_profile(doc, environ={ROBOT_ENV: "ur5"}) is BUILTIN["ur5"]
    assert from_profile(doc, environ={ROBOT_ENV: "panda"}).base_xyz_m == (0.1, -0.3, -0.23)


@pytest.mark.parametrize("table, message", [
    ({"model": "kuka"}, "unknown robot model 'kuka'; known: "),
    ({"model": "panda", "reach_m": 2}, "unknown key 'reach_m'"),
    ({"model": "panda", "gripper": {"force_max_n": -1.0}}, "gripper.force_max_n must be a positive number"),
    ({"model": "panda", "gripper": {"stiffness": 1}}, "unknown key(s) ['stiffness']"),
    ({"model": "panda", "home_rad": [0.0, 0.1]}, "home_rad needs 7 values"),
    ({"model": "ur5", "base_xyz_m": [0.0, "x", 0.0]}, "base_xyz_m must be a list of numbers"),
    ({"model": "so_arm101", "velocity_scale": 1.5}, "velocity_scale must be in (0, 1]"),
])
def test_bad_robot_tables_are_refused_with_the_key_named(table, message):
    with pytest.raises(RobotDescriptionError) as err:
        from_profile({"robot": table}, "deploy/x.toml", environ={})
    assert message in str(err.value)


def test_a_placed_arm_answers_in_the_scene_frame():
    """The URDF root sits at `base_xyz_m`: forward kinematics include the placement."""
    panda = describe("panda")
    moved = describe("panda", {"base_xyz_m": [panda.base_xyz_m[0] + 0.1, panda.base_xyz_m[1], panda.base_xyz_m[2]]})
    q = np.array(panda.home_rad)
    p0 = robots.ArmModel(panda).tool_pose(q)[0]
    p1 = robots.ArmModel(moved).tool_pose(q)[0]
    assert p1 - p0 == pytest.approx([0.1, 0.0, 0.0], abs=1e-9)
    base = robots.ArmModel(panda).frame_positions(q, ["panda_link0"])[0]
    assert base == pytest.approx(panda.base_xyz_m, abs=1e-9)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_every_tool_frame_points_its_jaws_down_with_one_convention(name):
    """z approach, y the jaw axis: the upright grasp (UPRIGHT_ROTATION) is reachable from home
    at the object's pick place, with the same joint limits the URDF gives."""
    arm = describe(name)
    model = robots.ArmModel(arm)
    assert model.joint_names == arm.joints
    assert np.all(np.array(arm.home_rad) >= model.limits.lower_rad) and np.all(
        np.array(arm.home_rad) <= model.limits.upper_rad)
    ik = ArmIk(MotionConfig.from_dict({}, arm), arm)
    result = ik.solve(np.array(arm.object_pick_base_m), UPRIGHT_ROTATION, np.array(arm.home_rad))
    position, rotation = model.tool_pose(result.q_rad)
    assert position == pytest.approx(arm.object_pick_base_m, abs=2e-3)
    assert rotation[:, 2] == pytest.approx([0.0, 0.0, -1.0], abs=0.03)


@pytest.mark.parametrize("name", sorted(BUILTIN))
def test_each_arm_reaches_the_pick_the_lift_and_typical_transfer_points(name):
    arm = describe(name)
    ik = ArmIk(MotionConfig.from_dict({}, arm), arm)
    obj = np.array(arm.object_pick_base_m)
    goals = [obj + [0, 0, 0.10], obj, obj + [0, 0, 0.15], *map(np.array, TYPICAL_TRANSFER_M[name])]
    for goal in goals:
        r = ik.solve(goal, UPRIGHT_ROTATION, np.array(arm.home_rad))
        assert r.position_error_m <= 1e-3, (name, goal)
    # And the arm does not reach everywhere: a point 2 m away is refused.
    with pytest.raises(Exception, match="out of reach|no progress|did not converge"):
        ik.solve(np.array([2.0, -0.26, 0.0]), UPRIGHT_ROTATION, np.array(arm.home_rad))


def test_the_gripper_limits_reach_the_contact_plant():
    from robot_sim.contact.config import SimConfig
    from robot_sim.handover_scene import HandoverScene, SceneParams

    g = BUILTIN["baxter"].gripper  # Baxter's gripper is the plant's default actuator, exactly
    assert SimConfig().with_gripper(g.force_rate_n_s, g.loop_rate_hz, g.force_max_n, g.force_min_n) == SimConfig()

    for name in BUILTIN:
        g = describe(name).gripper
        plant = HandoverScene(SceneParams(gripper=g))._config.gripper
        assert plant.max_force_n == min(g.force_max_n, 140.0)
        assert plant.force_rate_n_per_s == pytest.approx(g.force_rate_n_s)
        assert plant.loop_rate_hz == g.loop_rate_hz
        assert plant.min_force_n == g.force_min_n


def test_a_minimum_grip_force_holds_soft_commands_up_and_zero_opens():
    from robot_sim.contact.actuator import GripperActuator
    from robot_sim.contact.config import GripperParams

    act = GripperActuator(GripperParams(min_force_n=20.0), 0.001, np, 3, 0.0)
    assert act.target_for(np.array([5.0, 0.0, 50.0])) * 500.0 == pytest.approx([20.0, -0.0, 50.0])


def test_the_baxter_hardware_backend_refuses_another_arm():
    from services.bridge.baxter.backend import BaxterBackend
    from services.bridge.baxter.errors import BaxterConfigError

    previous = robots.active()
    robots.use(describe("panda"))
    try:
        with pytest.raises(BaxterConfigError, match="the profile's arm is 'panda'"):
            BaxterBackend(None)  # type: ignore[arg-type]  # refused before the profile is read
    finally:
        robots.use(previous)
