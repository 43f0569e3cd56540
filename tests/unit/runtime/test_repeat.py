"""RepeatGate: a held command goes out on a change or once per repeat period; a stepped one
always."""

from __future__ import annotations

import pytest

from services.runtime.repeat import HOLD_REPEAT_S, RepeatGate


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
