"""Sender stamps never go back within one process, even when the host's clock does."""

from __future__ import annotations

import threading

from services.motion.goal_filter import GoalFilter
from services.runtime.stamps import SENDER_CLOCK, SenderClock

S = 1_000_000_000  # 1 s in ns
T0 = 1_700_000_000 * S


class SteppedWallClock:
    """A wall clock the test sets by hand (ns since the epoch)."""

    def __init__(self, now_ns: int) -> None:
        self.now_ns = now_ns

    def __call__(self) -> int:
        return self.now_ns


def test_stamps_follow_the_wall_clock_and_count_on_through_a_backward_step():
    wall = SteppedWallClock(T0)
    clock = SenderClock(wall)
    assert clock.now_ns() == T0
    assert clock.now_ns() == T0 + 1  # same wall reading: still strictly after the last stamp
    wall.now_ns = T0 + S
    assert clock.now_ns() == T0 + S
    wall.now_ns = T0 - 3600 * S  # NTP steps the clock an hour back
    assert [clock.now_ns() for _ in range(3)] == [T0 + S + 1, T0 + S + 2, T0 + S + 3]
    wall.now_ns = T0 + 2 * S  # the clock has caught up: stamps follow it again
    assert clock.now_ns() == T0 + 2 * S


def test_a_goal_sent_after_a_stop_is_acted_on_although_the_clock_stepped_back_between_them():
    wall = SteppedWallClock(T0)
    clock = SenderClock(wall)
    raw_stop_ns, stop_ns = wall(), clock.now_ns()
    wall.now_ns = T0 - 10 * S  # the supervisor's host clock steps back 10 s after the stop
    raw_goal_ns, goal_ns = wall(), clock.now_ns()
    # With raw wall-clock stamps the new goal would look older than the stop and be ignored:
    raw = GoalFilter()
    raw.stop_seen("supervisor", raw_stop_ns)
    assert raw.reason_to_ignore("supervisor", "e1-retract-4", 0, raw_goal_ns) == "sent before a stop"
    # With the sender clock it is after the stop, as it was sent.
    f = GoalFilter()
    f.stop_seen("supervisor", stop_ns)
    assert f.reason_to_ignore("supervisor", "e1-retract-4", 0, goal_ns) is None


def test_stamps_are_unique_and_increasing_across_threads():
    wall = SteppedWallClock(T0)  # a frozen wall clock: every stamp comes from the counting on
    clock = SenderClock(wall)
    per_thread: list[list[int]] = [[] for _ in range(4)]

    def stamp(out: list[int]) -> None:
        for _ in range(5000):
            out.append(clock.now_ns())

    threads = [threading.Thread(target=stamp, args=(out,)) for out in per_thread]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    every = [s for out in per_thread for s in out]
    assert len(set(every)) == 20_000
    assert sorted(every) == list(range(T0, T0 + 20_000))
    assert all(a < b for out in per_thread for a, b in zip(out, out[1:]))


def test_messages_on_the_bus_carry_increasing_stamps_across_publishers(make_node):
    from bus_schema import topics
    from services.runtime.testing import wait_until

    sender, listener = make_node("supervisor"), make_node("listener")
    stops = listener.subscribe(topics.MOTION_STOP, 100)
    goals = listener.subscribe(topics.MOTION_GOAL, 100)
    stop_pub, goal_pub = sender.publisher(topics.MOTION_STOP), sender.publisher(topics.MOTION_GOAL)
    # A put before the listener's subscriptions have reached the router is lost: send until
    # one message of each key got through, then judge only what is sent afterwards.
    seen = {"stop": False, "goal": False}

    def routed() -> bool:
        stop_pub.put(reason="release")
        goal_pub.put(goal_id="warm-up", kind="retract")
        seen["stop"] |= bool(stops.drain())
        seen["goal"] |= bool(goals.drain())
        return seen["stop"] and seen["goal"]

    assert wait_until(routed, 10.0, interval_s=0.05), f"no route from sender to listener: {seen}"
    before = SENDER_CLOCK.now_ns()
    sent = []
    for i in range(3):
        sent.append(stop_pub.put(reason="release"))
        sent.append(goal_pub.put(goal_id=f"g{i}", kind="retract"))
    stamps = [m.stamp_ns for m in sent]
    assert before < stamps[0] and all(a < b for a, b in zip(stamps, stamps[1:]))
    got: list = []

    def all_received() -> bool:
        got.extend(r.msg for r in (*stops.drain(), *goals.drain()) if r.msg.stamp_ns > before)
        return len(got) == 6

    assert wait_until(all_received, 5.0)
    assert sorted(m.stamp_ns for m in got) == stamps
