"""A supervisor killed or frozen mid-episode, on a real bus, with no launcher job.

`handover-up --job none` runs the profile's episode with no job. Killed, the supervisor is
stopped by the bridge by itself (its watch of the supervisor's liveliness token; the launcher's
monitor sends its own stop too, which this test does not need). Frozen, its token stays up:
only the launcher's watch of its state sees it, which the ``none`` job runs too.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import psutil
import pytest

from bus_schema import topics
from services.launcher.logins import OBSERVER, login_profile
from services.runtime import ServiceNode
from services.runtime.testing import free_tcp_port, loopback_profile, wait_until

pytestmark = pytest.mark.integration

#: The bridge's stop must be sent within this of the kill, s (its own bound is 100 ms p99; CI
#: machines are busy and this is one run).
STOP_WITHIN_S = 0.5


def _supervisor(launcher: subprocess.Popen) -> psutil.Process | None:
    try:
        children = psutil.Process(launcher.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return None
    for child in children:
        try:
            if "services.supervisor" in " ".join(child.cmdline()):
                return child
        except psutil.NoSuchProcess:
            pass
    return None


def _stop_launcher(proc: subprocess.Popen) -> str:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=40)
    except subprocess.TimeoutExpired:
        for child in psutil.Process(proc.pid).children(recursive=True):
            child.kill()
        proc.kill()
        out, _ = proc.communicate()
    return out


@dataclass
class FaultRun:
    """What a `handover-up --job none` run showed around one fault of the supervisor in the
    reach: the stops sent, the joint states, when the fault came (ns, host clock), the
    launcher's output and exit code."""

    stops: list
    joint_states: list
    fault_ns: int
    output: str
    exit_code: int | None


def _fault_in_the_reach(tmp_path, fault: Callable[[psutil.Process], None], stop_source: str) -> FaultRun:
    """Run the stack with no job, apply `fault` to the supervisor 0.3 s into the reach, wait
    for a stop from `stop_source` and 1 s more, then stop the stack (a stopped supervisor is
    resumed first)."""
    port = free_tcp_port()
    proc = subprocess.Popen([sys.executable, "-m", "services.launcher", "--port", str(port), "--recording-dir",
                             str(tmp_path), "--run-id", "t", "--job", "none"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    node = supervisor = None
    received: list = []
    published: list = []
    fault_ns = 0
    try:
        node = ServiceNode(OBSERVER, login_profile(loopback_profile(port), tmp_path, "t", OBSERVER),
                           install_signal_handlers=False, connect_timeout_s=30)
        node.open()
        states = node.subscribe(topics.SUPERVISOR_STATE, queue_size=10_000)
        stops = node.subscribe(topics.MOTION_STOP, queue_size=100)
        joints = node.subscribe(topics.JOINT_STATE, queue_size=100_000)
        seen: list = []

        def in_reach() -> bool:
            seen.extend(rx.msg for rx in states.drain())
            return any(m.phase == "reach" for m in seen)

        assert wait_until(in_reach, 60), f"no reach: {[m.phase for m in seen][-5:]}"
        time.sleep(0.3)  # the arm is on its way
        supervisor = _supervisor(proc)
        assert supervisor is not None
        fault_ns = time.time_ns()
        fault(supervisor)

        def stopped() -> bool:
            received.extend(rx.msg for rx in stops.drain())
            return any(m.source == stop_source for m in received)

        wait_until(stopped, 5)
        time.sleep(1.0)  # the brake's ramp, and the holding arm after it
        received.extend(rx.msg for rx in stops.drain())
        published = [rx.msg for rx in joints.drain()]
        try:
            proc.wait(timeout=30)  # the launcher fails the run and stops the stack by itself
        except subprocess.TimeoutExpired:
            pass
    finally:
        if supervisor is not None and supervisor.is_running():
            supervisor.resume()
        if node is not None:
            node.close()
        exit_code = proc.poll()
        out = _stop_launcher(proc)
    return FaultRun(received, published, fault_ns, out, exit_code)


def _one_stop_then_at_rest(run: FaultRun, source: str) -> Any:
    """The one stop `source` sent, within `STOP_WITHIN_S` of the fault; the arm was moving
    at the fault and is at rest, holding, 0.1 s after the stop (the brake takes 25 ms from
    1 rad/s; the launcher stops the stack meanwhile, the bridge among the last)."""
    own = [m for m in run.stops if m.source == source]
    assert len(own) == 1, f"stops: {run.stops}\n{run.output}"
    stop = own[0]
    assert 0 <= (stop.stamp_ns - run.fault_ns) / 1e9 < STOP_WITHIN_S, (stop.stamp_ns - run.fault_ns) / 1e9
    before = [m for m in run.joint_states if m.stamp_ns <= run.fault_ns]
    after = [m for m in run.joint_states if m.stamp_ns >= stop.stamp_ns + 100_000_000]
    assert before and len(after) >= 3, f"{len(before)} joint states before the fault, {len(after)} after"
    assert np.max(np.abs(before[-1].velocity_rad_s)) > 0.01
    assert all(m.holding for m in after)
    assert np.max(np.abs([m.velocity_rad_s for m in after])) < 1e-6
    return stop


def test_a_supervisor_killed_in_the_reach_is_stopped_by_the_bridge(tmp_path):
    run = _fault_in_the_reach(tmp_path, lambda p: p.send_signal(signal.SIGKILL), "bridge")
    stop = _one_stop_then_at_rest(run, "bridge")
    assert stop.protective and "supervisor lost" in stop.reason and "during reach" in stop.reason
    # Any other stop is the launcher's monitor's, for the supervisor's exit.
    assert {m.source for m in run.stops} <= {"bridge", "launcher"}, run.stops
    assert "supervisor was killed by SIGKILL" in run.output


def test_a_supervisor_frozen_in_the_reach_is_stopped_by_the_launcher_with_no_job(tmp_path):
    run = _fault_in_the_reach(tmp_path, lambda p: p.suspend(), "launcher")
    stop = _one_stop_then_at_rest(run, "launcher")
    assert stop.protective and "supervisor: silent: no supervisor/state" in stop.reason, stop.reason
    assert run.exit_code == 1, run.output[-2000:]
    assert "exit 1: supervisor: silent: no supervisor/state" in run.output, run.output[-2000:]
