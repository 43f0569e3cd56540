"""A service's heartbeat (`runtime/heartbeat`): sent from a thread of its own on the host's
shared grid, so that a frozen (SIGSTOP) or dead process falls silent at once while a long
computation in the main loop does not look like a fault. A wake of that thread more than
`LATE_WAKE_REPORT_S` late is logged with why (`services.runtime.starvation`: no CPU, or no
GIL; at most one line per 5 s).

The periods: `HEARTBEAT_PERIOD_S` on one host, `MULTIHOST_HEARTBEAT_PERIOD_S` across hosts
(`heartbeat_period_s`).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from typing import Any

from services.runtime.clock import WALL_GRID_PHASE_S
from services.runtime.logs import RateLimitedLog
from services.runtime.loop import RateLoop
from services.runtime.profile import Profile
from services.runtime.starvation import LATE_WAKE_REPORT_S, WakeSampler, late_wake_report

log = logging.getLogger(__name__)

#: Period of every service's heartbeat (`runtime/heartbeat`) on one host, s. There the
#: supervisor asks the kernel whether a quiet service was killed (its pidfd) or stopped
#: (state ``T``), so a beat need not also carry that news fast: one beat every 0.1 s
#: still shows a stopped service within 0.13 s
#: (`services.supervisor.watchdog.judging_for_beats`), and each beat costs
#: a thread wake in the sender and a hop through the router to the supervisor and the
#: recorder (issue 16: 80 fewer messages a second on the idle stack).
HEARTBEAT_PERIOD_S = 0.1
#: Heartbeat period on a bus that spans hosts (``bus.allow_non_loopback``), s: the
#: supervisor cannot read another host's processes, so a frozen one is only a silence.
MULTIHOST_HEARTBEAT_PERIOD_S = 0.05


def heartbeat_period_s(profile: Profile) -> float:
    """The services' heartbeat period under `profile`, s."""
    return MULTIHOST_HEARTBEAT_PERIOD_S if profile.allow_non_loopback else HEARTBEAT_PERIOD_S


class Heartbeat:
    """One service's heartbeats through `publisher` (a `TypedPublisher` of `runtime/heartbeat`
    with its own stamps), every `period_s` s until `stop_event` is set.

    Args:
        name: the service (thread name, log lines).
        publisher: the heartbeat's publisher.
        period_s: the beat period, s.
        stop_event: ends the beat thread.
    """

    def __init__(self, name: str, publisher: Any, period_s: float, stop_event: threading.Event) -> None:
        self.name = name
        self.period_s = period_s
        self._publisher = publisher
        self._stop_event = stop_event
        self._lock = threading.Lock()
        self._beats = 0
        self._next_beat_s = 0.0
        self._started_s = time.monotonic()

    def start(self) -> None:
        """Send the first beat now and the others from a thread of their own."""
        self.beat_if_due()
        threading.Thread(target=self._beat_forever, name=f"{self.name} heartbeat", daemon=True).start()

    def beat_if_due(self) -> None:
        """Send a beat now if the last one is at least a period old (any thread)."""
        with self._lock:
            if time.monotonic() < self._next_beat_s:
                return
        self._beat()

    def _beat_forever(self) -> None:
        """A beat every period on a fixed grid (one wake per beat), saying why when a wake came
        late (the `/proc` figures are read at every wake, parsed only for a late one)."""
        period_s = self.period_s
        late_log = RateLimitedLog(log, 5.0)
        with WakeSampler() as sampler:  # opened here: it samples this thread
            previous = sampler.raw()
            # On the host's shared grid: the first beat is at its first point, up to a period on.
            beats = RateLoop(1.0 / period_s, self._stop_event, name=f"{self.name} heartbeat",
                             align_phase_s=WALL_GRID_PHASE_S)
            for _tick in beats:
                now = sampler.raw()
                self._beat()
                lateness_s = now.monotonic_s - previous.monotonic_s - period_s
                if lateness_s > LATE_WAKE_REPORT_S:  # says whether the process lacked CPU or the GIL
                    report = late_wake_report(previous.parsed(), now.parsed(), period_s)
                    if report is not None:  # a diagnostic: a silence that matters is the supervisor's warning
                        late_log.info("late heartbeat", f"{self.name}: {report}")
                previous = now

    def _beat(self) -> None:
        """Send one beat (the thread's grid, and `beat_if_due`)."""
        now = time.monotonic()
        with self._lock:
            self._next_beat_s = now + self.period_s
            beats = self._beats
            self._beats += 1
        try:
            self._publisher.put(uptime_s=min(now - self._started_s, 86400.0), beats=beats, pid=os.getpid())
        except Exception as exc:  # noqa: BLE001 - closing session: the heartbeat must never kill a service
            log.debug("heartbeat not sent: %s", exc)
