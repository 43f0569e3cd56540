"""The recorder's stop sequence: late messages still in flight are recorded, bounded in time."""

from __future__ import annotations

import queue
import threading
import time

from services.recorder.node import drain, settle


class Collect:
    def __init__(self) -> None:
        self.keys: list[str] = []

    def handle(self, key, payload, receive_ns) -> None:
        self.keys.append(key)


def _feed(inbox, n, gap_s):
    for i in range(n):
        time.sleep(gap_s)
        inbox.put((f"k{i}", b"", i))


def test_settle_takes_messages_arriving_after_the_stop_until_the_bus_is_quiet():
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    writer = Collect()
    feeder = threading.Thread(target=_feed, args=(inbox, 5, 0.04))
    feeder.start()
    t0 = time.monotonic()
    settle(inbox, writer, quiet_s=0.6, max_s=10.0)  # 0.6 s of quiet: 15× the feeder's gap
    elapsed = time.monotonic() - t0
    feeder.join()
    assert writer.keys == [f"k{i}" for i in range(5)]
    assert 0.6 <= elapsed < 5.0  # returned on quiet, long before max_s


def test_settle_is_bounded_when_messages_never_stop():
    inbox: queue.SimpleQueue = queue.SimpleQueue()
    writer = Collect()
    feeder = threading.Thread(target=_feed, args=(inbox, 100, 0.02), daemon=True)
    feeder.start()
    t0 = time.monotonic()
    settle(inbox, writer, quiet_s=0.15, max_s=0.5)
    elapsed = time.monotonic() - t0
    assert 0.45 <= elapsed < 1.5
    assert 5 <= len(writer.keys) < 100
    feeder.join()
    drain(inbox, writer)
    assert writer.keys == [f"k{i}" for i in range(100)]
