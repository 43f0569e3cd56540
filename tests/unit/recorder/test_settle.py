"""The recorder's stop sequence: late messages still in flight are collected, bounded in time."""

from __future__ import annotations

import threading
import time
from collections import deque

from services.recorder.node import settle


class Source:
    """A key's channel fed by a thread; `collect` takes what arrived (as the writer does)."""

    def __init__(self) -> None:
        self.channel: deque = deque()
        self.collected: list[int] = []

    def feed(self, n: int, gap_s: float) -> None:
        for i in range(n):
            time.sleep(gap_s)
            self.channel.append(i)

    def collect(self) -> int:
        n = len(self.channel)
        self.collected += [self.channel.popleft() for _ in range(n)]
        return n


def test_settle_collects_messages_arriving_after_the_stop_until_the_bus_is_quiet():
    source = Source()
    feeder = threading.Thread(target=source.feed, args=(5, 0.04))
    feeder.start()
    waited = settle(source.collect, quiet_s=0.6, max_s=10.0)  # 0.6 s of quiet: 15× the feeder's gap
    feeder.join()
    assert source.collected == list(range(5))
    assert 0.6 <= waited < 5.0  # returned on quiet, long before max_s


def test_settle_is_bounded_when_messages_never_stop():
    source = Source()
    feeder = threading.Thread(target=source.feed, args=(100, 0.02), daemon=True)
    feeder.start()
    waited = settle(source.collect, quiet_s=0.15, max_s=0.5)
    assert 0.45 <= waited < 1.5
    assert 5 <= len(source.collected) < 100
    feeder.join()
    source.collect()
    assert source.collected == list(range(100))
