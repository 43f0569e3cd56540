"""The planner rests only while a supervisor that still speaks is outside an episode (issue 16)."""

from __future__ import annotations

import pytest

from services.planner.core import REST_PHASES, SUPERVISOR_STATE_FRESH_S, planner_rests


@pytest.mark.parametrize("phase, age_s, rests", [
    (None, 0.0, False),                                   # no supervisor heard: full rate
    ("idle", 0.0, True), ("done", 0.5, True), ("failed", 0.0, True), ("protective_stop", 1.0, True),
    ("locate", 0.0, False), ("pick", 0.0, False), ("plan", 0.0, False), ("reach", 0.0, False),
    ("transfer", 0.0, False), ("released", 0.0, False), ("retract", 0.0, False), ("hold", 0.0, False),
    ("done", SUPERVISOR_STATE_FRESH_S + 0.01, False),     # a silent supervisor says nothing any more
])
def test_the_planner_rests_only_outside_an_episode_of_a_supervisor_that_speaks(phase, age_s, rests):
    assert planner_rests(phase, age_s) is rests


def test_every_rest_phase_is_a_phase_of_the_supervisor():
    from typing import get_args

    from bus_schema.messages.supervisor import SupervisorPhase

    assert set(REST_PHASES) <= set(get_args(SupervisorPhase))
