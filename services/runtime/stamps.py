"""The sender's stamp of every message: wall clock, never going back within one process.

`stamp_ns` in the common header is the sender's wall clock (`time.time_ns()`). Two messages
of one source are ordered by it (a motion goal against a stop: `services.motion.goal_filter`
and the bridge's `StopBrake`), so it must not go back when the host's clock is stepped back
(NTP, an operator's `date -s`): a goal sent after a stop would then look older than the stop
and be ignored until the clock caught up.

`SenderClock.now_ns()` returns the wall clock, but always at least 1 ns more than the last
stamp it gave in this process: after a backward step it counts on from the last stamp
until the clock catches up, so stamps of one process are strictly increasing across all its
publishers and threads. Across processes and hosts nothing is promised (and nothing compares
them): freshness is judged by local receive time.

On the simulation clock (`services.runtime.clock`) the process's stamps follow the simulated
time instead (`SenderClock.follow`): ns since the run's start, still strictly increasing.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class SenderClock:
    """Strictly increasing wall-clock stamps (ns since the Unix epoch) for one process.

    Args:
        wall_ns: the wall clock to follow (`time.time_ns`; tests pass a fake one).
    """

    def __init__(self, wall_ns: Callable[[], int] = time.time_ns) -> None:
        self._wall_ns = wall_ns
        self._last_ns = 0
        self._lock = threading.Lock()

    def follow(self, clock_ns: Callable[[], int]) -> None:
        """Stamp with `clock_ns` from now on (the simulation clock's time, ns)."""
        with self._lock:
            self._wall_ns = clock_ns
            self._last_ns = 0

    def now_ns(self) -> int:
        """The next stamp: the wall clock, or the last stamp + 1 ns if the clock is behind it."""
        with self._lock:
            stamp_ns = max(self._wall_ns(), self._last_ns + 1)
            self._last_ns = stamp_ns
            return stamp_ns


#: The process's one sender clock: every `TypedPublisher` stamps with it.
SENDER_CLOCK = SenderClock()
