"""`ContactPlant.advance_real_time`: plant time follows the caller's time at an irregular rate."""

from __future__ import annotations

import numpy as np
import pytest

from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import taking


def _plant():
    return ContactPlant(SimConfig(), taking(), seed=0)


def test_short_extra_ticks_do_not_run_the_plant_ahead():
    plant = _plant()
    # A 100 Hz loop where every period also has a 0.3 ms urgent tick (a stop woke it):
    # 100 periods = 1.000 s of real time = 1000 plant steps of 1 ms, not 1100 (the plant's
    # step counter counts every step, run in full or replayed at rest).
    for _ in range(100):
        plant.advance_real_time(0.0003, 10.0)
        plant.advance_real_time(0.0097, 10.0)
    assert plant.step_index == 1000
    # Late ticks run more steps; the fraction carries over.
    plant.advance_real_time(0.0125, 10.0)
    assert plant.step_index == 1012
    plant.advance_real_time(0.0005, 10.0)
    assert plant.step_index == 1013


def test_same_trajectory_as_whole_step_advances():
    a, b = _plant(), _plant()
    for _ in range(50):
        a.advance(0.010, 10.0)
        b.advance_real_time(0.004, 10.0)
        b.advance_real_time(0.006, 10.0)
    oa, ob = a.observation(), b.observation()
    assert oa.time_s == pytest.approx(ob.time_s) == pytest.approx(0.5)
    for field in ("wrist_force_x_n", "wrist_force_y_n", "grip_force_n", "object_position_x_m",
                  "object_position_y_m", "object_velocity_y_m_s"):
        assert np.allclose(getattr(oa, field), getattr(ob, field)), field


def test_bad_elapsed_time_is_refused():
    with pytest.raises(ContactSimError):
        _plant().advance_real_time(float("nan"), 10.0)
