"""The Franka backend's pure logic: velocity command, the Hand's actions, error words, the
robot's clock, the config's presets and errors, and the command gate's step rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.bridge.core import CommandGate
from services.bridge.franka import core
from services.bridge.franka.config import PRESETS, parse_franka_config
from services.bridge.franka.errors import FrankaConfigError

LIMIT = np.full(7, 1.0)


def test_velocity_command_is_feedforward_plus_gain_times_error_clipped():
    target = np.array([0.1, 0, 0, 0, 0, 0, 0.0])
    measured = np.zeros(7)
    ff = np.array([0.2, 0, 0, 0, 0, 0, -3.0])
    v = core.velocity_command(target, ff, measured, 5.0, LIMIT)
    assert v[0] == pytest.approx(0.2 + 5.0 * 0.1)
    assert v[6] == pytest.approx(-1.0)                 # clipped to the limit
    assert np.all(v[1:6] == 0.0)
    assert core.velocity_command(target, None, measured, 0.0, LIMIT) == pytest.approx(np.zeros(7))


def test_grip_planner_opens_at_once_and_throttles_grasps():
    plan = core.GripPlanner(max_force_n=70.0, min_force_n=1.0, deadband_n=2.0, min_interval_s=0.1)
    assert plan.plan(30.0, 0.0) == core.GripAction("grasp", 30.0)
    assert plan.plan(31.0, 0.5) is None                # inside the dead band
    assert plan.plan(40.0, 0.55) == core.GripAction("grasp", 40.0)
    assert plan.plan(50.0, 0.60) is None               # too soon after the last grasp
    assert plan.plan(0.0, 0.61) == core.GripAction("open")   # an open is never delayed
    assert plan.plan(0.0, 0.62) is None                # nor repeated
    assert plan.plan(200.0, 0.63) == core.GripAction("grasp", 70.0)
    assert plan.clipped == 1
    assert plan.plan(math.nan, 0.64) == core.GripAction("open")


def test_describe_errors_groups_flags_by_what_to_check():
    text = core.describe_errors(["joint_reflex", "communication_constraints_violation", "something_new"])
    assert text.startswith("collision reflex")
    assert "joint_reflex" in text and "communication" in text and "other: something_new" in text
    assert core.describe_errors([]) == ""

    class Errors:
        joint_reflex = True
        cartesian_reflex = False

    assert core.active_flags(Errors(), ["joint_reflex", "cartesian_reflex", "missing"]) == ["joint_reflex"]


def test_state_clock_loses_the_robot_when_its_clock_stops():
    clock = core.StateClock(lost_after_s=0.2)
    assert clock.lost(0.0)                              # nothing read yet
    clock.update(100, 1.0)
    clock.update(100, 1.15)                             # the same stamp: not advancing
    assert not clock.lost(1.15)
    assert clock.lost(1.25)
    clock.update(101, 1.25)
    assert clock.silent_s(1.30) == pytest.approx(0.05)


def test_config_presets_margin_and_overrides():
    cfg = parse_franka_config({"model": "fr3", "limit_margin_rad": 0.05})
    limits = cfg.limits()
    assert limits.upper_rad[0] == pytest.approx(PRESETS["fr3"]["upper_rad"][0] - 0.05)
    assert cfg.names()[0] == "fr3_joint1"
    assert parse_franka_config({}).names() == tuple(f"panda_joint{i}" for i in range(1, 8))
    custom = parse_franka_config({"velocity_rad_s": [1.0] * 7, "joint_names": list("abcdefg")})
    assert custom.limits().velocity_rad_s == pytest.approx(np.ones(7)) and custom.names()[0] == "a"


@pytest.mark.parametrize("table, words", [
    ({"lower_rad": [0.0] * 3}, "lower_rad needs 7 values"),
    ({"relative_dynamics_factor": 2.0}, "relative_dynamics_factor"),
    ({"bogus": 1}, "bogus"),
    ({"lower_rad": [1.0] * 7, "upper_rad": [1.05] * 7}, "below its upper_rad"),
])
def test_config_errors_name_the_key(table, words):
    with pytest.raises(FrankaConfigError, match="invalid \\[services.bridge.config.franka\\]") as info:
        parse_franka_config(table)
    assert words in str(info.value)


def test_gate_refuses_a_jump_and_holds():
    cfg = parse_franka_config({})
    names = cfg.names()
    gate = CommandGate(names, cfg.limits(), 0.2, 1e-3, max_step_rad=0.1)
    current = np.array([0.0, 0.0, 0.0, -1.5, 0.0, 1.5, 0.0])
    near = current.copy()
    near[0] += 0.09
    assert gate.offer(names, near.tolist(), 0.0, current) is None
    far = current.copy()
    far[1] += 0.11
    reason = gate.offer(names, far.tolist(), 0.01, current)
    assert reason is not None and "panda_joint2 jumps 0.110 rad" in reason
    decision = gate.decide(0.02)
    assert decision.holding and decision.target_rad is None and gate.rejected == 1
    # Without the rule (the simulated arm) the same command is taken.
    free = CommandGate(names, cfg.limits(), 0.2, 1e-3)
    assert free.offer(names, far.tolist(), 0.0, current) is None
