"""`ServiceNode.publisher` gives one publisher per topic: every part of a service sends through
one numbering, so readers that take each (source, seq) once (the recorder) lose nothing."""

from __future__ import annotations

import pytest

from bus_schema import topics
from services.runtime.errors import BusError
from services.runtime.liveliness import alive_services
from services.runtime.testing import wait_until


def test_two_asks_for_one_topic_give_one_publisher_and_one_numbering(bus, make_node):
    sender, reader = make_node("sender"), make_node("reader")
    states = reader.subscribe(topics.SUPERVISOR_STATE, queue_size=16)
    reader.ready()  # alive means listening: once its token is seen, a put reaches it
    assert wait_until(lambda: "reader" in alive_services(sender.session, bus[0].prefix, 0.3), 5.0)
    first, second = sender.publisher(topics.SUPERVISOR_STATE), sender.publisher(topics.SUPERVISOR_STATE)
    assert first is second
    assert sender.publisher(topics.MOTION_STOP) is not first
    first.put(phase="idle")
    second.put(phase="locate")
    received: list = []
    assert wait_until(lambda: received.extend(states.drain()) or len(received) >= 2, 5.0)
    assert [(rx.msg.seq, rx.msg.phase) for rx in received] == [(0, "idle"), (1, "locate")]


def test_a_topic_asked_again_with_other_stamps_is_refused(make_node):
    node = make_node("sender")
    with pytest.raises(BusError, match="runtime/heartbeat already has a publisher with own_stamps=True"):
        node.publisher(topics.HEARTBEAT)  # the node's heartbeat publisher keeps its own stamps
    node.publisher(topics.MOTION_STOP)
    with pytest.raises(BusError, match="motion/stop already has a publisher with own_stamps=False"):
        node.publisher(topics.MOTION_STOP, own_stamps=True)
