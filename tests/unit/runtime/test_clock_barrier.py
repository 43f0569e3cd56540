"""The simulation clock's barrier (`services.runtime.clock_barrier`): when time may move, who
is due, event steps, and participants that leave or vanish."""

from __future__ import annotations

from services.runtime.clock import EVENT_STEP_NS
from services.runtime.clock_barrier import NEVER_NS, ClockBarrier

MS = 1_000_000


def _registered(*names: str) -> ClockBarrier:
    barrier = ClockBarrier(frozenset(names))
    for name in names:
        barrier.ready(name, 0, 1 * MS, pid=100)
    return barrier


def test_no_step_before_every_expected_participant_answered():
    barrier = ClockBarrier(frozenset({"motion", "gripper"}))
    barrier.ready("motion", 0, 1 * MS)
    assert not barrier.started and barrier.unregistered() == ["gripper"]
    assert barrier.next_step(10 * MS) is None
    barrier.ready("gripper", 0, 1 * MS)
    step = barrier.next_step(10 * MS)
    assert step is not None and step.time_ns == 1 * MS and step.due == ("gripper", "motion")
    assert not step.owner_due


def test_time_moves_to_the_earliest_need_and_waits_for_every_due_participant():
    barrier = _registered("motion", "gripper")
    first = barrier.next_step(0)  # the owner's own tick at 0 comes first
    assert first is not None and first.time_ns == 0 and first.owner_due and first.due == ()
    step = barrier.next_step(10 * MS)
    assert step is not None and (step.time_ns, step.due) == (1 * MS, ("gripper", "motion"))
    barrier.ready("motion", 1 * MS, 11 * MS)
    assert barrier.waiting_for() == ["gripper"]
    assert barrier.next_step(10 * MS) is None  # the gripper still owes the 1 ms step
    barrier.ready("gripper", 1 * MS, 4 * MS)
    step = barrier.next_step(10 * MS)
    assert step is not None and (step.time_ns, step.due, step.owner_due) == (4 * MS, ("gripper",), False)
    barrier.ready("gripper", 4 * MS, 11 * MS)
    step = barrier.next_step(10 * MS)
    assert step is not None and (step.time_ns, step.due, step.owner_due) == (10 * MS, (), True)
    assert barrier.now_ns == 10 * MS and barrier.steps == 4


def test_an_event_gives_every_participant_a_step_one_microsecond_later():
    barrier = _registered("motion", "supervisor")
    step = barrier.next_step(10 * MS)
    assert step is not None and step.time_ns == 1 * MS
    barrier.ready("supervisor", 1 * MS, 11 * MS, events=True)  # it sent a goal at 1 ms
    barrier.ready("motion", 1 * MS, 11 * MS)
    event = barrier.next_step(10 * MS)
    assert event is not None and event.time_ns == 1 * MS + EVENT_STEP_NS
    assert event.due == ("motion", "supervisor") and event.owner_due
    barrier.ready("motion", event.time_ns, 11 * MS)
    barrier.ready("supervisor", event.time_ns, 11 * MS)
    after = barrier.next_step(10 * MS)
    assert after is not None and after.time_ns == 10 * MS  # back to the grid


def test_a_participant_that_leaves_or_is_excused_is_not_waited_for_until_it_answers_again():
    barrier = _registered("motion", "gripper")
    barrier.next_step(10 * MS)
    barrier.ready("motion", 1 * MS, 0, leaving=True)
    assert barrier.participants["motion"].next_ns == NEVER_NS
    barrier.excuse("gripper")  # e.g. its process was stopped
    assert barrier.excusals == 1 and barrier.waiting_for() == []
    step = barrier.next_step(10 * MS)
    assert step is not None and step.time_ns == 10 * MS and step.due == ()
    barrier.ready("gripper", 1 * MS, 5 * MS)  # SIGCONT: it answers the step it was in
    assert not barrier.participants["gripper"].excused
    assert barrier.participants["gripper"].next_ns == 10 * MS  # never in the past
    step = barrier.next_step(20 * MS)
    assert step is not None and step.time_ns == 10 * MS and step.due == ("gripper",)


def test_an_answer_to_an_older_step_does_not_count_for_the_current_one():
    barrier = _registered("motion")
    barrier.next_step(10 * MS)
    barrier.ready("motion", 1 * MS, 5 * MS)
    step = barrier.next_step(10 * MS)
    assert step is not None and step.time_ns == 5 * MS and barrier.waiting_for() == ["motion"]
    barrier.ready("motion", 1 * MS, 6 * MS)  # late copy of the previous answer
    assert barrier.waiting_for() == ["motion"]
    barrier.ready("motion", 5 * MS, 6 * MS)
    assert barrier.waiting_for() == []


def test_an_answer_in_a_name_the_clock_does_not_expect_is_ignored():
    barrier = _registered("motion")
    assert barrier.ready("ghost", 0, 1 * MS, pid=1) is False
    assert "ghost" not in barrier.participants
    step = barrier.next_step(10 * MS)
    assert step is not None and step.due == ("motion",)


def test_a_restarted_participant_is_taken_back_with_its_new_process():
    barrier = _registered("planner")
    barrier.next_step(10 * MS)  # the planner (pid 100) is due at 1 ms and dies before answering
    assert barrier.waiting_for() == ["planner"]
    barrier.ready("planner", 0, 1 * MS, pid=200)  # its replacement's first answer: an older step's
    assert barrier.pid_of("planner") == 100 and barrier.waiting_for() == ["planner"]
    barrier.excuse("planner")  # the owner finds pid 100 gone
    barrier.ready("planner", 0, 1 * MS, pid=200)  # the replacement repeats its answer
    assert barrier.pid_of("planner") == 200 and not barrier.participants["planner"].excused
    step = barrier.next_step(10 * MS)
    assert step is not None and step.due == ("planner",) and step.time_ns == 1 * MS


def test_a_stale_repeat_of_an_answer_with_events_makes_no_second_event_step():
    """A participant blocked on the clock repeats its last answer once a second (wall time). A
    repeat of an answer that said it sent an event, arriving just after the owner granted the
    event step, is an answer to an older step: it must not make another event step, or the
    number of steps (and the gripper's event-step ticks) would depend on the wall clock."""
    barrier = _registered("motion", "supervisor")
    barrier.next_step(10 * MS)  # 1 ms: both due
    barrier.ready("supervisor", 1 * MS, 11 * MS, events=True)  # it sent a goal at 1 ms
    barrier.ready("motion", 1 * MS, 11 * MS)
    event = barrier.next_step(10 * MS)
    assert event is not None and event.time_ns == 1 * MS + EVENT_STEP_NS
    barrier.ready("supervisor", 1 * MS, 11 * MS, events=True)  # its repeat, sent before the grant reached it
    assert barrier.waiting_for() == ["motion", "supervisor"]  # ignored as an answer…
    barrier.ready("motion", event.time_ns, 11 * MS)
    barrier.ready("supervisor", event.time_ns, 11 * MS)
    after = barrier.next_step(10 * MS)
    assert after is not None and after.time_ns == 10 * MS  # …and as an event: back to the grid
