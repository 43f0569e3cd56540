"""The simulation clock (`services.runtime.clock`, `clock_owner`): grids from time 0, the
participant's answers, and on a real loopback bus an owner and a participant stepping together,
each message taken in only after the step that sent it."""

from __future__ import annotations

import dataclasses
import threading

import pytest

from bus_schema import topics
from services.runtime import ServiceNode
from services.runtime.clock import (CLOCK_ENV, PARTICIPANT_PHASE_S, ClockError, SimClock, clock_source,
                                    first_grid_time_s, grid_phase_s, seconds_to_ns)
from services.runtime.clock_owner import ClockOwner, expected_participants
from services.runtime.loop import RateLoop
from services.runtime.testing import wait_until


def test_grids_start_at_their_phase_and_the_owner_is_at_phase_zero():
    assert first_grid_time_s(0.0, 0.01, 0.0) == 0.0
    assert first_grid_time_s(0.0, 0.01, 0.001) == pytest.approx(0.001)
    assert first_grid_time_s(0.0105, 0.01, 0.001) == pytest.approx(0.011)
    assert first_grid_time_s(0.011, 0.01, 0.001) == pytest.approx(0.011)  # on a point: that point
    assert grid_phase_s("bridge") == 0.0 and grid_phase_s("gripper") == PARTICIPANT_PHASE_S == 0.001
    assert seconds_to_ns(0.0099999999999) == 10_000_000


def test_the_environment_overrides_the_profile_and_a_bad_name_is_refused(monkeypatch):
    monkeypatch.delenv(CLOCK_ENV, raising=False)
    assert clock_source(None) == "wall" and clock_source("sim") == "sim"
    monkeypatch.setenv(CLOCK_ENV, "sim")
    assert clock_source("wall") == "sim"
    monkeypatch.setenv(CLOCK_ENV, "lunar")
    with pytest.raises(ClockError, match="unknown clock 'lunar'"):
        clock_source("wall")


def test_expected_participants_leave_out_the_owner_and_the_recorder():
    assert expected_participants(["bridge", "motion", "recorder", "gripper"], "bridge", None) == {"motion", "gripper"}
    assert expected_participants(["bridge", "motion"], "bridge", "motion, tracker,") == {"motion", "tracker"}


def test_an_aligned_loop_ticks_on_its_grid_on_a_stepped_clock():
    """A loop paced by a clock that jumps to whatever deadline it is asked for ticks exactly at
    phase + k · period (whole ns), never early and never twice at one time."""
    now_ns = [3_000_000]  # the loop starts 3 ms in: its first tick is at the next grid point
    stop = threading.Event()

    def wait(timeout_s: float) -> None:
        now_ns[0] += max(1, seconds_to_ns(timeout_s))

    ticks = []
    loop = RateLoop(100.0, stop, clock=lambda: now_ns[0] / 1e9, wait=wait, align_phase_s=0.001, tolerance_s=1e-6)
    for index in loop:
        ticks.append(now_ns[0])
        if index == 199:
            break
    assert ticks[:3] == [11_000_000, 21_000_000, 31_000_000]
    assert all(b - a == 10_000_000 for a, b in zip(ticks, ticks[1:]))
    assert loop.stats.overruns == 0 and len(ticks) == 200


def test_an_aligned_grid_does_not_drift_over_a_long_run():
    """k · period from the phase, not a float sum: after 100 000 ticks (1 000 s at 100 Hz) a tick
    is still on the whole-ns grid, where another loop's tick of the same time is."""
    now_ns = [0]
    stop = threading.Event()
    loop = RateLoop(100.0, stop, clock=lambda: now_ns[0] / 1e9,
                    wait=lambda t: now_ns.__setitem__(0, now_ns[0] + max(1, seconds_to_ns(t))),
                    align_phase_s=0.001, tolerance_s=1e-6)
    for index in loop:
        if index == 100_000:
            break
    assert now_ns[0] == 1_000_001_000_000


class _Sent:
    """A stand-in for the ready publisher: records every answer."""

    def __init__(self) -> None:
        self.answers: list[dict] = []

    def put(self, **fields) -> None:
        self.answers.append(fields)


def test_a_participant_answers_then_waits_for_a_step_that_names_it():
    clock = SimClock("motion")
    sent = clock._ready_pub = _Sent()
    clock.on_grant(0, 0, named=False)
    returned = threading.Event()

    def participant() -> None:
        clock.wait(0.010)
        returned.set()

    thread = threading.Thread(target=participant)
    thread.start()
    assert wait_until(lambda: sent.answers, 2.0)
    assert sent.answers[0]["done_ns"] == 0 and sent.answers[0]["next_ns"] == 10_000_000
    clock.on_grant(1, 5_000_000, named=False)  # a step for somebody else: keep waiting, time unmoved
    assert not returned.wait(0.2) and clock.now_ns() == 0
    clock.note_event()
    clock.on_grant(2, 10_000_000, named=True)
    assert returned.wait(2.0) and clock.now_ns() == 10_000_000 and clock.steps == 1
    thread.join(2.0)
    # Before its first step it said it again now and then (the owner may have started later).
    assert all(a == sent.answers[0] for a in sent.answers) and sent.answers[-1]["events"] is False
    answered = len(sent.answers)
    again = threading.Thread(target=clock.wait, args=(0.0,))
    again.start()  # no wait at all is still a step on: 1 ns, never the same instant again
    assert wait_until(lambda: len(sent.answers) == answered + 1, 2.0)
    assert sent.answers[-1]["next_ns"] == 10_000_001 and sent.answers[-1]["events"] is True
    clock.on_grant(3, 10_000_001, named=True)
    again.join(2.0)
    assert not again.is_alive() and clock.now_ns() == 10_000_001


def test_answer_early_lets_the_clock_go_on_while_the_results_are_computed():
    """A sensor pipeline answers at once with its latency: the owner may step others meanwhile;
    what it sends is stamped at now + latency, and a step that names it while it is still at
    work changes neither its time nor its stamps until its wait takes that step."""
    clock = SimClock("tracker")
    sent = clock._ready_pub = _Sent()
    clock.answer_early(0.020)
    assert sent.answers[-1]["done_ns"] == 0 and sent.answers[-1]["next_ns"] == 20_000_000
    assert clock.stamp_ns() == 20_000_000 and clock.now_ns() == 0
    clock.on_grant(5, 20_000_000, named=True)  # the owner got there before the work was done
    assert clock.now_ns() == 0 and clock.stamp_ns() == 20_000_000
    answers = len(sent.answers)
    assert clock.wait(0.0333)  # the step is taken at once; no second answer for the same step
    assert len(sent.answers) == answers
    assert clock.now_ns() == 20_000_000 and clock.stamp_ns() == 20_000_000


def _sim(profile):
    return dataclasses.replace(profile, clock="sim")


def test_owner_and_participant_step_together_and_a_message_counts_from_the_next_step(bus, monkeypatch):
    """On a real bus: the owner ticks at 0, 10, 20 ms, the participant at 1, 11, 21 ms; the
    participant sees the owner's sample of the same period, the owner sees the participant's
    at its next tick, never at the tick it was sent in."""
    profile, _ = bus
    monkeypatch.setenv(CLOCK_ENV + "_PARTICIPANTS", "motion")
    owner = ServiceNode("bridge", _sim(profile), install_signal_handlers=False, clock_role="owner")
    participant = ServiceNode("motion", _sim(profile), install_signal_handlers=False)
    owner.open()
    participant.open()
    try:
        assert isinstance(owner.clock, ClockOwner) and isinstance(participant.clock, SimClock)
        to_motion = owner.publisher(topics.JOINT_STATE)
        to_owner = participant.publisher(topics.JOINT_COMMAND)
        seen_by_motion, seen_by_owner = [], []
        states = participant.subscribe(topics.JOINT_STATE, wake=False)
        commands = owner.subscribe(topics.JOINT_COMMAND, wake=False)
        participant.ready()
        owner.ready()

        def run_motion() -> None:
            for tick in participant.loop(100.0):
                now = participant.clock.now_ns()
                seen_by_motion.append((now, [r.msg.seq for r in states.drain()]))
                to_motion_seq = tick
                to_owner.put(names=["right_s0"], position_rad=[0.0], goal_id=f"c{to_motion_seq}")
                if tick == 4:
                    break
            participant.clock.close()  # leaving: the owner no longer waits for it

        thread = threading.Thread(target=run_motion)
        thread.start()
        for tick in owner.loop(100.0):
            now = owner.clock.now_ns()
            seen_by_owner.append((now, [r.msg.goal_id for r in commands.drain()]))
            to_motion.put(names=["right_s0"], position_rad=[0.0], velocity_rad_s=[0.0], effort_nm=[0.0])
            if tick == 5:
                break
        thread.join(10.0)
    finally:
        participant.close()
        owner.close()
    assert [t for t, _ in seen_by_owner] == [0, 10_000_000, 20_000_000, 30_000_000, 40_000_000, 50_000_000]
    assert seen_by_motion == [(1_000_000, [0]), (11_000_000, [1]), (21_000_000, [2]), (31_000_000, [3]),
                              (41_000_000, [4])]
    assert seen_by_owner[:3] == [(0, []), (10_000_000, ["c0"]), (20_000_000, ["c1"])]
