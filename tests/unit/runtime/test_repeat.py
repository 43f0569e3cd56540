"""RepeatGate: a held command goes out on a change or once per repeat period; a stepped one
always."""

from __future__ import annotations

import pytest

from services.runtime.repeat import HOLD_REPEAT_S, SETTLED_RESOLUTION, RepeatGate, settled_key


def test_an_unchanged_command_goes_out_once_per_repeat_period():
    gate = RepeatGate(0.045)
    # 100 Hz for one second, the same command throughout: a copy every fifth tick.
    sent = [k for k in range(100) if gate.due((0.0, "open"), k * 0.01)]
    assert sent == list(range(0, 100, 5))
    assert (gate.sent, gate.skipped) == (20, 80)


def test_a_change_goes_out_at_once_and_restarts_the_period():
    gate = RepeatGate(0.05)
    assert gate.due((1.0,), 0.0)
    assert not gate.due((1.0,), 0.01)
    assert gate.due((2.0,), 0.02)
    assert not gate.due((2.0,), 0.06)  # 40 ms after the change
    assert gate.due((2.0,), 0.07)


def test_a_stepped_command_always_goes_out():
    gate = RepeatGate(0.05)
    assert all(gate.due((3.0,), k * 0.01, always=True) for k in range(10))
    assert gate.skipped == 0


def test_the_bridge_gets_a_copy_well_inside_its_command_timeout():
    assert HOLD_REPEAT_S <= 0.2 / 4


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan")])
def test_a_non_positive_period_is_refused(bad):
    with pytest.raises(ValueError, match="repeat_s"):
        RepeatGate(bad)


def test_settled_key_ignores_a_rounding_dither_and_sees_a_nanometre():
    # The receiver holding the object at rest: velocities dither by 1e-17 m/s from tick to tick.
    a = {"v": (4.163336342344374e-15, 0.0, 6.040920286415252e-17), "held_by": "receiver", "dropped": False}
    b = {"v": (4.163336342344374e-15, 0.0, 5.929897983952736e-17), "held_by": "receiver", "dropped": False}
    assert settled_key(a.values()) == settled_key(b.values())
    assert tuple(a.values()) != tuple(b.values())  # bit for bit they differ
    moved = {**a, "v": (4.163336342344374e-15, 0.0, 3 * SETTLED_RESOLUTION)}
    assert settled_key(moved.values()) != settled_key(a.values())
    assert settled_key([(0.1,), "receiver"]) != settled_key([(0.1,), "none"])
    assert settled_key([True]) != settled_key([False])


def test_settled_key_keeps_non_finite_values_apart():
    assert settled_key([float("inf")]) != settled_key([1e300])
    assert settled_key([float("-inf")]) != settled_key([float("inf")])
    nan_key = settled_key([float("nan")])
    assert isinstance(nan_key[0], float) and nan_key[0] != nan_key[0]  # NaN: always "changed"


def test_a_dithering_value_is_sent_once_per_repeat_period():
    gate = RepeatGate(0.095)  # 100 Hz ticks: a copy every tenth (0.1 s is 10 ticks, bar rounding)
    dither = (6.040920286415252e-17, 6.151942588877767e-17, 5.929897983952736e-17)
    sent = [k for k in range(100) if gate.due(settled_key([(0.0, 0.0, dither[k % 3])]), k * 0.01)]
    assert sent == list(range(0, 100, 10))
