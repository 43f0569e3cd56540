"""ServiceNode: alive means listening (the token follows the subscriptions); only waking
subscriptions wake `wait()`. Real Zenoh sessions on a loopback router in this process."""

from __future__ import annotations

import time

import pytest

from bus_schema import topics
from services.runtime.liveliness import alive_services
from services.runtime.node import ServiceNode, open_session
from services.runtime.testing import BusRouter, loopback_profile, wait_until


@pytest.fixture()
def bus():
    profile = loopback_profile()
    with BusRouter(profile):
        peer = open_session(profile, "client", timeout_s=5.0)
        try:
            yield profile, peer
        finally:
            peer.close()


def _put_stop(profile, peer, seq: int) -> None:
    from bus_schema import encode_for

    msg = topics.MOTION_STOP.type(seq=seq, stamp_ns=time.time_ns(), source="test", reason="test")
    peer.put(topics.MOTION_STOP.key(profile.prefix), encode_for(topics.MOTION_STOP, msg))


def test_token_only_after_ready_and_a_put_at_first_sight_is_heard(bus):
    profile, peer = bus
    node = ServiceNode("probe", profile, install_signal_handlers=False)
    with node:
        assert "probe" not in alive_services(peer, profile.prefix, 0.3)
        assert not node.is_ready
        stops = node.subscribe(topics.MOTION_STOP)
        node.ready()
        assert wait_until(lambda: "probe" in alive_services(peer, profile.prefix, 0.3), 5.0)
        _put_stop(profile, peer, 0)  # published the moment the token is seen
        assert wait_until(lambda: stops.stats.accepted == 1, 5.0)


def test_first_wait_declares_the_token(bus):
    profile, peer = bus
    with ServiceNode("probe2", profile, install_signal_handlers=False) as node:
        node.subscribe(topics.MOTION_STOP)
        node.wait(0.0)
        assert node.is_ready
        assert wait_until(lambda: "probe2" in alive_services(peer, profile.prefix, 0.3), 5.0)


def test_only_waking_subscriptions_wake_wait(bus):
    profile, peer = bus
    with ServiceNode("probe3", profile, install_signal_handlers=False) as node:
        quiet = node.subscribe(topics.MOTION_STOP, wake=False)
        node.ready()
        assert wait_until(lambda: "probe3" in alive_services(peer, profile.prefix, 0.3), 5.0)  # listening
        node.wait(0.0)  # clear
        _put_stop(profile, peer, 0)
        assert wait_until(lambda: quiet.stats.accepted == 1, 5.0)
        assert node.wait(0.05) is False, "a wake=False subscription woke the loop"
        assert quiet.latest() is not None
    with ServiceNode("probe4", profile, install_signal_handlers=False) as node:
        loud = node.subscribe(topics.MOTION_STOP)
        node.ready()
        assert wait_until(lambda: "probe4" in alive_services(peer, profile.prefix, 0.3), 5.0)
        node.wait(0.0)
        _put_stop(profile, peer, 1)
        assert wait_until(lambda: loud.stats.accepted == 1, 5.0)
        assert node.wait(0.05) is True


def test_a_rested_subscription_runs_no_python_per_sample_and_catches_up_in_order(bus):
    """``wakes_loop = False``: samples wait in a ring channel (nothing decoded, no wake) until
    the loop reads them or wakes the subscription again; then they come first, in order."""
    profile, peer = bus
    with ServiceNode("probe5", profile, install_signal_handlers=False) as node:
        sub = node.subscribe(topics.MOTION_STOP)
        node.ready()
        assert wait_until(lambda: "probe5" in alive_services(peer, profile.prefix, 0.3), 5.0)
        node.wait(0.0)
        sub.wakes_loop = False
        for seq in range(3):
            _put_stop(profile, peer, seq)
        peer.put(topics.MOTION_STOP.key(profile.prefix), b"\xc1 not msgpack")
        assert node.wait(0.3) is False, "a sample woke a loop at rest"
        assert sub._stats.received == 0, "a sample was taken in by a callback while at rest"
        sub.wakes_loop = True  # what waited is taken in now, before anything newer
        assert sub._stats.received == 4
        _put_stop(profile, peer, 3)
        assert node.wait(5.0) is True
        assert [rx.msg.seq for rx in sub.drain()] == [0, 1, 2, 3]
        assert sub.stats.rejected == 1 and sub.stats.duplicates == 0
        sub.wakes_loop = False
        _put_stop(profile, peer, 4)
        assert wait_until(lambda: sub.latest() is not None and sub.latest().msg.seq == 4, 5.0)  # read at a tick


def test_switching_rest_and_wake_under_a_stream_loses_and_repeats_nothing(bus):
    """A 1 kHz stream while the reader rests and wakes its subscription 40 times: every
    message is taken in exactly once, in order, with no sequence gap."""
    import threading

    profile, peer = bus
    n = 1500
    with ServiceNode("probe6", profile, install_signal_handlers=False) as node:
        sub = node.subscribe(topics.MOTION_STOP, queue_size=2048)
        node.ready()
        assert wait_until(lambda: "probe6" in alive_services(peer, profile.prefix, 0.3), 5.0)

        def send() -> None:
            for seq in range(n):
                _put_stop(profile, peer, seq)
                time.sleep(0.001)

        sender = threading.Thread(target=send)
        sender.start()
        got = []
        while sender.is_alive():
            sub.wakes_loop = not sub.wakes_loop
            time.sleep(0.02)
            got += [rx.msg.seq for rx in sub.drain()]
        sender.join()
        sub.wakes_loop = True
        assert wait_until(lambda: (got.extend(rx.msg.seq for rx in sub.drain()) or got[-1:] == [n - 1]), 5.0)
        assert got == list(range(n))
        assert sub.stats.seq_gaps == 0 and sub.stats.overflowed == 0


def test_only_exact_copies_are_dropped_once_a_subscription_has_rested(bus):
    """Across a switch a sample may reach both ways: the exact copy (source, seq, stamp) is
    dropped and counted; a restarted publisher's message with an old seq but a new stamp is
    not a copy."""
    from services.runtime.pubsub import Received

    profile, _peer = bus
    with ServiceNode("probe7", profile, install_signal_handlers=False) as node:
        sub = node.subscribe(topics.MOTION_STOP)
        node.ready()
        sub.wakes_loop = False
        sub.wakes_loop = True

        def stop(seq: int, stamp_ns: int):
            return topics.MOTION_STOP.type(seq=seq, stamp_ns=stamp_ns, source="bridge", reason="t")

        for msg in (stop(7, 1_000), stop(7, 1_000), stop(8, 2_000), stop(7, 3_000)):
            sub._take(Received(msg, 0.0))
        assert [(rx.msg.seq, rx.msg.stamp_ns) for rx in sub.drain()] == [(7, 1_000), (8, 2_000), (7, 3_000)]
        assert sub.stats.duplicates == 1


def test_wake_if_wakes_only_for_the_messages_it_accepts_and_queues_every_one(bus):
    """`wake_if`: each message is decoded and queued, only those it says yes to wake `wait()`;
    a predicate that raises wakes the loop (a doubtful sample is never slept through)."""
    profile, peer = bus
    with ServiceNode("probe5", profile, install_signal_handlers=False) as node:
        def wake_if(msg) -> bool:
            if msg.seq == 2:
                raise ValueError("a broken predicate")
            return msg.seq % 2 == 1

        sub = node.subscribe(topics.MOTION_STOP, wake_if=wake_if)
        node.ready()
        assert wait_until(lambda: "probe5" in alive_services(peer, profile.prefix, 0.3), 5.0)
        node.wait(0.0)
        woke = []
        for seq in range(4):
            _put_stop(profile, peer, seq)
            assert wait_until(lambda seq=seq: sub.stats.accepted == seq + 1, 5.0)
            # A wake comes just after the count: wait long for one expected, briefly for none.
            woke.append(node.wait(0.2 if seq == 0 else 5.0))
        assert woke == [False, True, True, True]  # 0: no; 1: yes; 2: the predicate raised; 3: yes
        assert [rx.msg.seq for rx in sub.drain()] == [0, 1, 2, 3]


def test_a_read_at_the_tick_queue_of_one_decodes_only_the_newest(bus):
    """``wake=False, queue_size=1`` (the supervisor's and motion's joint states and wrench,
    read at their ticks): of a burst that waited, Zenoh's ring keeps only the newest, and only
    that one is decoded; a queue of 64 decodes every one."""
    profile, peer = bus
    with ServiceNode("probe8", profile, install_signal_handlers=False) as node:
        newest = node.subscribe(topics.MOTION_STOP, queue_size=1, wake=False)
        every = node.subscribe(topics.MOTION_STOP, queue_size=64, wake=False)
        node.ready()
        assert wait_until(lambda: "probe8" in alive_services(peer, profile.prefix, 0.3), 5.0)
        for seq in range(5):
            _put_stop(profile, peer, seq)
        assert wait_until(lambda: every.stats.received == 5, 5.0)
        time.sleep(0.2)  # Zenoh hands each sample to the two rings one after the other
        assert [rx.msg.seq for rx in newest.drain()] == [4]
        assert newest.stats.received == 1
        assert [rx.msg.seq for rx in every.drain()] == [0, 1, 2, 3, 4]
