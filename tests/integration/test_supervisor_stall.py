"""A supervisor that was itself starved does not call healthy services silent.

Real processes on a loopback bus: the bridge (100 Hz joint states, 20 Hz heartbeats) and the
supervisor. The supervisor is stopped (SIGSTOP) for 0.5 s, as a starved process would be, then
continued: the bridge's messages of that time wait in the supervisor's socket. It must take
them in before judging freshness, not report the bridge silent (which would be a protective
stop in an episode). A bridge frozen for as long is still reported.
"""

from __future__ import annotations

import os
import signal
import time

import pytest

from services.runtime.testing import ServiceProcess, wait_alive

pytestmark = pytest.mark.integration


def _pause(proc: ServiceProcess, seconds: float) -> None:
    os.kill(proc.pid, signal.SIGSTOP)
    try:
        time.sleep(seconds)
    finally:
        os.kill(proc.pid, signal.SIGCONT)


def test_a_starved_supervisor_takes_queued_messages_in_before_judging(bus):
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge, \
            ServiceProcess("services.supervisor", profile) as supervisor:
        wait_alive(router, profile, {"bridge", "supervisor"})
        time.sleep(1.5)  # the supervisor has seen the bridge's stream and heartbeat
        for _ in range(3):
            _pause(supervisor, 0.5)
            time.sleep(0.6)
        log = supervisor.log_text()
        assert "service fault service=bridge" not in log, log[-2000:]
        # It knew it had been stalled. Whether it also had to take queued messages in depends
        # on which thread ran first after SIGCONT (its callbacks may already have let the
        # bridge's messages in): either way the stall is logged, and nobody is called silent.
        assert "supervisor loop was" in log, log[-2000:]
        # The same pause of the bridge is a real silence, and is reported.
        _pause(bridge, 0.5)
        time.sleep(0.3)
        assert "service fault service=bridge what=silent" in supervisor.log_text()
