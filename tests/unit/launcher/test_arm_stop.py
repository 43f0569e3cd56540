"""The launcher's monitor stops the arm itself when a safety service dies in the job (issue 16:
the stop used to go through two more threads, once 133 ms beside the Rerun viewer), and
`ArmStop` sends one stop at most, only while the job's node is open, and never raises."""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from bus_schema import topics
from services.launcher.arm_stop import ArmStop
from services.launcher.core import LaunchOptions
from services.launcher.handover_job import _EpisodeFeed
from services.launcher.supervisor_silence import SupervisorSilence
from services.launcher.node import Launcher
from services.launcher.processes import Child
from services.runtime.liveliness import alive_services
from services.runtime.profile import load_profile_file
from services.runtime.testing import wait_until


class FakePublisher:
    def __init__(self, fail: bool = False, on_put=None) -> None:
        self.fail = fail
        self.on_put = on_put
        self.puts: list[tuple[dict, str]] = []

    def put(self, **fields):
        self.puts.append((fields, threading.current_thread().name))
        if self.on_put is not None:
            self.on_put()
        if self.fail:
            raise RuntimeError("session closed")


def test_one_stop_at_most_and_only_while_attached():
    arm_stop = ArmStop()
    assert arm_stop.send("early") is False          # no node open yet: nothing to send with
    publisher = FakePublisher()
    arm_stop.attach(publisher)
    assert arm_stop.send("supervisor was killed by SIGKILL") is True
    assert arm_stop.send("gripper exited with code 1") is False
    assert publisher.puts == [({"reason": "protective stop: supervisor was killed by SIGKILL",
                                "protective": True}, threading.current_thread().name)]
    assert arm_stop.sent_reason == "supervisor was killed by SIGKILL"
    arm_stop.detach()
    assert ArmStop().send("x") is False


def test_a_failing_put_is_not_raised():
    arm_stop = ArmStop()
    arm_stop.attach(FakePublisher(fail=True))
    assert arm_stop.send("bridge was killed by SIGKILL") is False


class NoLiveliness:
    def events(self):
        return []


@pytest.mark.timeout(30)
def test_the_monitor_stops_the_arm_when_a_safety_service_dies_in_the_job(tmp_path: Path):
    launcher = Launcher(load_profile_file("sim"), LaunchOptions(run_id="t", recording_dir=tmp_path))
    child = Child("supervisor", [sys.executable, "-c", "import time; time.sleep(60)"], 10, verbose=False)
    child.start()
    try:
        launcher.children["supervisor"] = child
        launcher.wakeup.watch("supervisor", child.pid)
        launcher.episode_running = True
        failure_at_put: list[str | None] = []
        publisher = FakePublisher(on_put=lambda: failure_at_put.append(launcher.failure))
        launcher.arm_stop.attach(publisher)
        monitor = threading.Thread(target=launcher._monitor, args=(NoLiveliness(),), name="monitor")
        monitor.start()
        child.proc.send_signal(signal.SIGKILL)
        monitor.join(20.0)
        assert not monitor.is_alive()
        # Sent by the monitor itself, with no job running to send it.
        assert publisher.puts == [({"reason": "protective stop: supervisor was killed by SIGKILL; it is a "
                                              "safety service, not restarted mid-episode", "protective": True},
                                   "monitor")]
        assert launcher.failure is not None and launcher.stop_requested.is_set()
        # The failure was recorded before the put (which may wait on a full link): the job's
        # loop sees it meanwhile.
        assert failure_at_put == [launcher.failure]
    finally:
        if child.proc.poll() is None:
            child.proc.kill()
        try:
            child.proc.wait(5.0)
        except subprocess.TimeoutExpired:
            pass
        launcher.wakeup.close()


def test_the_jobs_stop_and_the_monitors_share_one_numbering_on_a_real_bus(bus, make_node):
    """Two publishers of one source would number their messages from 0 each, and the recorder
    logs a stop once per (source, seq): the job's stop after the monitor's would be lost from
    the recording. The monitor's `ArmStop` and the job's feed both ask the launcher's node for a
    ``motion/stop`` publisher, and get its one: the two stops arrive numbered 0 and 1."""
    launcher, reader = make_node("launcher"), make_node("reader")
    stops = reader.subscribe(topics.MOTION_STOP, queue_size=16)
    reader.ready()  # alive means listening: once its token is seen, a put reaches it
    assert wait_until(lambda: "reader" in alive_services(launcher.session, bus[0].prefix, 0.3), 5.0)
    arm_stop = ArmStop()
    arm_stop.attach(launcher.publisher(topics.MOTION_STOP))
    feed = _EpisodeFeed(launcher, say=lambda line: None, silence=SupervisorSilence())
    assert arm_stop.send("supervisor was killed by SIGKILL")
    assert not feed.stopped("supervisor was killed by SIGKILL").ok
    received: list = []
    assert wait_until(lambda: received.extend(stops.drain()) or len(received) >= 2, 5.0)
    assert [(rx.msg.source, rx.msg.seq) for rx in received] == [("launcher", 0), ("launcher", 1)]
    assert [rx.msg.reason for rx in received] == ["protective stop: supervisor was killed by SIGKILL"] * 2
