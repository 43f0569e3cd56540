"""A stalled bridge loop: the simulated robot goes on for its own command time-out, then holds."""

from __future__ import annotations

import numpy as np

from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from services.bridge.backend import SimBackend, make_backend
from services.bridge.config import ContactConfig

HOME = np.array(RIGHT_ARM_HOME_RAD)


def _moving(timeout_s=0.2):
    backend = SimBackend(initial_position_rad=HOME, robot_command_timeout_s=timeout_s)
    far = HOME.copy()
    far[0] += 1.0
    for _ in range(20):
        backend.command(far, np.array([0.8, 0, 0, 0, 0, 0, 0]))
        backend.step(0.01)
    return backend


def test_a_short_stall_is_one_plain_step():
    a, b = _moving(), _moving()
    a.catch_up(0.15)
    b.step(0.15)
    np.testing.assert_array_equal(a.read().position_rad, b.read().position_rad)


def test_a_long_stall_goes_on_for_the_timeout_then_holds():
    stalled, reference = _moving(), _moving()
    start = stalled.read().position_rad.copy()
    stalled.catch_up(1.0)
    reference.step(0.2)  # what the robot does before its own time-out
    went = stalled.read().position_rad
    np.testing.assert_allclose(went, reference.read().position_rad, atol=1e-3)  # held, so no more than that
    assert went[0] - start[0] > 0.1  # it did go on
    assert np.all(np.abs(stalled.read().velocity_rad_s) < 1e-3)  # and holds at the end
    longer = _moving(timeout_s=0.4)
    longer.catch_up(1.0)
    assert longer.read().position_rad[0] > went[0] + 0.1  # the time-out is what limits it


def test_the_handover_scene_advances_through_the_stall():
    backend = make_backend("sim", contact=ContactConfig(enabled=True, scenario="handover"),
                           initial_position_rad=HOME, robot_command_timeout_s=0.2)
    steps: list[float] = []
    real_step = backend.scene.step

    def counting_step(dt_s, *args):
        steps.append(dt_s)
        return real_step(dt_s, *args)

    backend.scene.step = counting_step
    backend.catch_up(0.0)  # nothing
    assert steps == []
    backend.catch_up(0.5)
    assert steps == [0.2, 0.3]  # on with the last command, then held: 0.5 s of scene time


def test_a_streamed_trajectory_is_not_carried_on_by_its_feed_forward():
    # Commanded to where the arm is, moving at 0.8 rad/s (a trajectory's setpoint): the stale
    # feed-forward must not push the arm 0.8 × 0.2 rad past the last position command.
    backend = SimBackend(initial_position_rad=HOME, robot_command_timeout_s=0.2)
    here = backend.read().position_rad.copy()
    backend.command(here, np.array([0.8, 0, 0, 0, 0, 0, 0]))
    backend.catch_up(1.0)
    assert abs(backend.read().position_rad[0] - here[0]) < 1e-6
