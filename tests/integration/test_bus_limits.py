"""The bus itself refuses a message above the cap (1 MiB + framing): a real router process with
the stack's Zenoh settings between two client sessions. The decoders' own cap
(`bus_schema.codec`) is the second line; this is the first, so that an oversized payload never
reaches a subscriber's process at all."""

from __future__ import annotations

import json
import threading
import time

import pytest

from bus_schema import MAX_PAYLOAD_BYTES
from bus_schema.codec import DecodeError, decode
from bus_schema.messages.supervisor import Heartbeat
from services.launcher.processes import RouterProcess
from services.runtime.zenoh_config import zenoh_config_dict
from services.runtime.testing import client_session, loopback_profile, wait_until


def _received(sizes: list[int]) -> list[int]:
    """Sizes of the payloads a subscriber receives when one client sends payloads of `sizes`
    bytes, in order, through a real router process with the stack's Zenoh settings."""
    profile = loopback_profile()
    router = RouterProcess(json.dumps(zenoh_config_dict(profile, "router")))
    router.start()
    try:
        sender, receiver = client_session(profile), client_session(profile)
        got: list[int] = []
        lock = threading.Lock()

        def on_sample(sample) -> None:
            with lock:
                got.append(len(sample.payload))

        key = f"{profile.prefix}/test/limits"
        sub = receiver.declare_subscriber(key, on_sample)
        try:
            time.sleep(0.3)  # the subscription reaches the router
            for size in sizes:
                sender.put(key, b"x" * size)
            sender.put(key, b"end")  # after the others: the link is still up
            assert wait_until(lambda: 3 in got, 10.0), got
            time.sleep(0.3)
            with lock:
                return [n for n in got if n != 3]
        finally:
            sub.undeclare()
            sender.close()
            receiver.close()
    finally:
        router.stop()


def test_a_payload_above_the_cap_never_reaches_a_subscriber_and_the_bus_goes_on():
    assert _received([1000, 5 << 20, 10]) == [1000, 10]


def test_after_a_large_allowed_message_an_oversized_one_is_refused_by_the_bus_or_the_decoder():
    """Zenoh 1.10.2 enforces `transport.link.rx.max_message_size` only until a first fragmented
    message of an allowed size was taken in on the link, and not always then (it varies from run to
    run). What the stack guarantees is checked: order is kept, the bus goes on, and whatever
    oversized payload gets through is refused by the decoders' cap (`bus_schema.codec`)."""
    allowed, oversized = MAX_PAYLOAD_BYTES - 4096, 5 << 20
    got = _received([allowed, oversized, 10])
    assert got in ([allowed, 10], [allowed, oversized, 10]), got
    with pytest.raises(DecodeError, match="exceeds"):
        decode(Heartbeat, b"x" * oversized)
