"""`seconds_to_next_look`: while the supervisor's states come, the handover job sleeps until the
newest could begin a silence worth noting (on the shared grid); otherwise it looks every
`WATCH_PERIOD_S`, as it always did."""

from __future__ import annotations

import pytest

from services.launcher.handover_job import WATCH_PERIOD_S, seconds_to_next_look
from services.launcher.supervisor_silence import NOTE_AFTER_S, SimClockSilence, SupervisorSilence
from services.runtime.clock import WALL_GRID_PHASE_S

GRID_0 = WALL_GRID_PHASE_S + 1000.0  # a point of the shared 20 ms grid


def _heard(at_s: float, episode_id: int = 1) -> SupervisorSilence:
    silence = SupervisorSilence()
    silence.heard(at_s, episode_id)
    return silence


@pytest.mark.parametrize("offset_s", [0.0, 0.003, 0.011, 0.019])
def test_a_fresh_state_puts_the_next_look_on_the_first_grid_point_after_it_could_be_quiet(offset_s):
    heard_s = GRID_0 + offset_s
    wait_s = seconds_to_next_look(_heard(heard_s), heard_s)
    look_s = heard_s + wait_s
    assert NOTE_AFTER_S <= look_s - heard_s < NOTE_AFTER_S + WATCH_PERIOD_S
    assert (look_s - GRID_0) / WATCH_PERIOD_S == pytest.approx(round((look_s - GRID_0) / WATCH_PERIOD_S), abs=1e-6)


def test_once_the_newest_state_is_old_enough_to_note_it_looks_every_watch_period():
    silence = _heard(GRID_0)
    for quiet_s in (NOTE_AFTER_S, NOTE_AFTER_S + 0.005, 0.15, 0.5):
        assert 0.0 < seconds_to_next_look(silence, GRID_0 + quiet_s) <= WATCH_PERIOD_S * 1.1


def test_before_the_first_episode_and_on_the_simulation_clock_it_looks_every_watch_period():
    assert seconds_to_next_look(_heard(GRID_0, episode_id=0), GRID_0) <= WATCH_PERIOD_S * 1.1
    assert seconds_to_next_look(SupervisorSilence(), GRID_0) <= WATCH_PERIOD_S * 1.1
    sim = SimClockSilence()
    sim.heard(GRID_0, 1, stamp_s=5.0)
    assert seconds_to_next_look(sim, GRID_0) <= WATCH_PERIOD_S * 1.1


def test_a_state_heard_just_before_a_grid_point_does_not_make_a_look_of_a_few_microseconds():
    heard_s = GRID_0 + WATCH_PERIOD_S - 1e-6
    now_s = heard_s + NOTE_AFTER_S - 1e-6  # the look point is 1 µs away: look on the grid instead
    assert seconds_to_next_look(_heard(heard_s), now_s) >= WATCH_PERIOD_S / 10
