"""`seconds_to_next_look`: while the supervisor's states come, the handover job sleeps until the
newest could begin a silence worth noting (on the shared grid); otherwise it looks every
`WATCH_PERIOD_S`, as it always did."""

from __future__ import annotations

import pytest

from services.launcher.handover_job import WATCH_PERIOD_S, seconds_to_next_look
from services.launcher.supervisor_silence import NOTE_AFTER_S, SimClockSilence, SupervisorSilence
from services.runtime.clock import WALL_GRID_PHASE_S

GRID_0 = WALL_GRID_PHASE_S + 1000.0  # a point of the shared 20 ms grid


def _heard(at_s: float, episode_id: int = 1, one_host: bool = True) -> SupervisorSilence:
    silence = SupervisorSilence(supervisor_pid=(lambda: None) if one_host else None)
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
    # across hosts: a state is timed by the look that takes it in, so the job looks as often as ever
    assert seconds_to_next_look(_heard(GRID_0, one_host=False), GRID_0) <= WATCH_PERIOD_S * 1.1
    sim = SimClockSilence()
    sim.heard(GRID_0, 1, stamp_s=5.0)
    assert seconds_to_next_look(sim, GRID_0) <= WATCH_PERIOD_S * 1.1


def test_a_state_heard_just_before_a_grid_point_does_not_make_a_look_of_a_few_microseconds():
    heard_s = GRID_0 + WATCH_PERIOD_S - 1e-6
    now_s = heard_s + NOTE_AFTER_S - 1e-6  # the look point is 1 µs away: look on the grid instead
    assert seconds_to_next_look(_heard(heard_s), now_s) >= WATCH_PERIOD_S / 10


# ---------------------------------------------------------------- when a state arrived
def test_the_arrival_is_the_send_time_between_the_two_looks_else_the_look_that_took_it_in():
    from services.launcher.handover_job import arrival_estimate_s

    assert arrival_estimate_s(taken_s=10.08, previous_look_s=10.0, sent_s=10.03) == 10.03
    assert arrival_estimate_s(taken_s=10.08, previous_look_s=10.0, sent_s=10.08) == 10.08
    # sent before the previous look, which did not see it: it waited in delivery (a busy
    # machine) or the stamp is off; timed by the look, as the job always timed states
    assert arrival_estimate_s(taken_s=10.08, previous_look_s=10.0, sent_s=9.95) == 10.08
    assert arrival_estimate_s(taken_s=10.08, previous_look_s=10.0, sent_s=7.0) == 10.08
    # a stamp after the look that took it in (a clock stepped back): the look
    assert arrival_estimate_s(taken_s=10.08, previous_look_s=10.0, sent_s=12.0) == 10.08


class _Ring:
    def __init__(self) -> None:
        self.waiting: list = []

    def drain(self) -> list:
        taken, self.waiting = self.waiting, []
        return taken


class _Node:
    def __init__(self) -> None:
        self.rings: dict = {}

    def subscribe(self, topic, **_kw):
        return self.rings.setdefault(topic.suffix, _Ring())

    def publisher(self, _topic):
        return None


def test_the_feed_times_a_state_by_when_it_was_sent_not_by_the_look_that_took_it_in():
    """A state sent 70 ms before the look that takes it in (the job sleeps up to 80 ms) counts
    as heard 70 ms ago: a freeze right after it is seen at its time, not 70 ms late."""
    import time

    from bus_schema import messages as m
    from bus_schema import topics
    from services.launcher.handover_job import _EpisodeFeed
    from services.runtime.pubsub import Received

    node = _Node()
    silence = SupervisorSilence(supervisor_pid=lambda: None)  # one host
    feed = _EpisodeFeed(node, lambda _line: None, silence)  # type: ignore[arg-type]
    feed.looked_s = time.monotonic() - 0.08
    sent_ns = time.time_ns() - 70_000_000
    state = m.SupervisorState(seq=1, stamp_ns=sent_ns, source="supervisor", phase="reach", episode_id=1,
                              grip_request="open")
    node.rings[topics.SUPERVISOR_STATE.suffix].waiting = [Received(state, time.monotonic())]
    feed.take_states()
    assert silence.last_state_s is not None
    assert time.monotonic() - silence.last_state_s >= 0.069  # timed by the look: ~0
    assert silence.silent_s() >= 0.069


def test_across_hosts_the_feed_times_a_state_by_the_look_that_took_it_in():
    """Another host's stamps are on its own clock: a state counts as heard when taken in."""
    import time

    from bus_schema import messages as m
    from bus_schema import topics
    from services.launcher.handover_job import _EpisodeFeed
    from services.runtime.pubsub import Received

    node = _Node()
    silence = SupervisorSilence()  # no process id: another host
    feed = _EpisodeFeed(node, lambda _line: None, silence)  # type: ignore[arg-type]
    feed.looked_s = time.monotonic() - 0.08
    state = m.SupervisorState(seq=1, stamp_ns=time.time_ns() - 5_000_000_000, source="supervisor", phase="reach",
                              episode_id=1, grip_request="open")
    taken_s = time.monotonic()
    node.rings[topics.SUPERVISOR_STATE.suffix].waiting = [Received(state, taken_s)]
    feed.take_states()
    assert silence.last_state_s == taken_s
