"""A still plant sleeps only where it may (`robot_sim.contact.rest`: ``may_sleep``).

The receiver holding the object after a handover never reaches a proven fixed point (its
hand dithers by 1e-19 m), so without sleep its physics is stepped at 1 kHz for ever. Asleep,
the state stays as it was, the sensors go on as in a proven rest, and the results differ from
full stepping by far less than anything a sensor or the truth can show; a new reference, a
grip command that moves the finger or ``may_sleep`` turned off wakes it.
"""

from __future__ import annotations

import pytest

from robot_sim.contact import rest as rest_module
from robot_sim.contact.config import SimConfig
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import behaviour_by_name
from robot_sim.contact.rest import _PHYSICS, SLEEP_AFTER_TICKS

TICK_S = 0.01
RELEASE_TICK = 300  # the gripper lets go; the receiver takes the object


def handed_over(may_sleep: bool, ticks: int = 1000, seed: int = 3) -> ContactPlant:
    """A plant whose receiver took the object and holds it still (after `ticks` 10 ms ticks)."""
    p = ContactPlant(SimConfig(), behaviour_by_name("taking"), seed=seed, initial_grip_force_n=10.0)
    for tick in range(ticks):
        p.may_sleep = may_sleep and tick >= RELEASE_TICK + 100
        p.run_real_time(TICK_S, 10.0 if tick < RELEASE_TICK else 0.0)
    assert p.left and p.holds and not p.dropped  # the receiver holds it
    return p


class Counting:
    """Counts the plant's full steps (`run_steps` calls, steps)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.calls = self.steps = 0
        real = rest_module.run_steps

        def counted(p, grip_command_n, n):
            self.calls += 1
            self.steps += n
            real(p, grip_command_n, n)

        monkeypatch.setattr(rest_module, "run_steps", counted)


def test_a_held_object_sleeps_and_its_sensors_go_on(monkeypatch):
    asleep, awake = handed_over(True), handed_over(False)
    assert asleep._rest is not None and not asleep._rest.proven
    assert awake._rest is None  # never proven: the dither
    frozen = tuple(getattr(asleep, n) for n in _PHYSICS)
    full = Counting(monkeypatch)
    samples = []
    for _ in range(1000):
        for p in (asleep, awake):
            p.run_real_time(TICK_S, 0.0)
        samples.append((asleep.ft.force_x_n, asleep.ft.force_y_n, awake.ft.force_x_n, awake.ft.force_y_n))
        assert asleep.optical.valid == awake.optical.valid
        assert asleep.step_index == awake.step_index
    assert full.steps == 1000 * 10  # only the awake plant stepped
    assert tuple(getattr(asleep, n) for n in _PHYSICS) == frozen
    # The same noise draws in the same order, of loads equal to within 1e-12 N.
    assert max(max(abs(a - c), abs(b - d)) for a, b, c, d in samples) < 1e-12
    assert abs(asleep.px - awake.px) < 1e-12 and abs(asleep.py - awake.py) < 1e-12
    assert abs(asleep.hx - awake.hx) < 1e-12 and abs(asleep.hy - awake.hy) < 1e-12


def test_no_sleep_unless_allowed_nor_before_the_plant_was_still_long_enough():
    p = handed_over(False)
    assert p._rest is None and p.still_ticks == 0
    p.may_sleep = True
    for tick in range(SLEEP_AFTER_TICKS):
        assert p._rest is None, tick
        p.run_real_time(TICK_S, 0.0)
    p.run_real_time(TICK_S, 0.0)
    assert p._rest is not None and not p._rest.proven


def test_turning_may_sleep_off_wakes_it(monkeypatch):
    p = handed_over(True)
    assert p._rest is not None
    full = Counting(monkeypatch)
    p.may_sleep = False
    p.run_real_time(TICK_S, 0.0)
    assert p._rest is None and full.steps == 10 and p.still_ticks == 0


def test_a_grip_command_that_moves_the_finger_wakes_it(monkeypatch):
    p = handed_over(True)
    full = Counting(monkeypatch)
    p.run_real_time(TICK_S, 10.0)  # the gripper closes again: the finger's target moves
    assert p._rest is None and full.steps == 10
    assert p.actuator.finger_m != p.actuator.target_m  # on its way
    for _ in range(SLEEP_AFTER_TICKS):
        p.run_real_time(TICK_S, 10.0)
        assert p._rest is None or p._rest.proven  # moving: no sleep


def test_a_new_receiver_wakes_it_and_a_falling_object_never_sleeps():
    p = handed_over(True)
    p.replace_receiver(behaviour_by_name("dropping"))
    assert p._rest is None and p.still_ticks == 0
    dropping = ContactPlant(SimConfig(), behaviour_by_name("dropping"), seed=1, initial_grip_force_n=10.0)
    dropping.may_sleep = True
    for tick in range(600):
        dropping.run_real_time(TICK_S, 10.0 if tick < RELEASE_TICK else 0.0)
        if dropping.dropped:
            break
        assert dropping._rest is None or dropping._rest.proven, tick
    assert dropping.dropped
