"""The launcher's freshness watch of the supervisor starts with the first episode: before it,
nothing can move the arm and a starved start-up must not stop the stack; from it on, a silent
supervisor is a protective stop by the launcher. Real Zenoh on loopback, the real job loop."""

from __future__ import annotations

import re
import threading
import time

from bus_schema import topics
from services.launcher.handover_job import SUPERVISOR_SILENT_S, run_handover_job
from services.runtime.testing import wait_until


def _start_job(make_node, abort: threading.Event):
    node = make_node("launcher")
    result: dict = {}
    lines: list[str] = []

    def run() -> None:
        result["job"] = run_handover_job(node, 1, lambda: "test over" if abort.is_set() else None, lines.append,
                                         episode_timeout_s=30.0)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return node, thread, result


def _states(pub, episode_id: int, phase: str, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        pub.put(phase=phase, episode_id=episode_id, grip_request="open")
        time.sleep(0.02)


def test_a_silence_before_the_first_episode_does_not_stop_the_arm(make_node):
    abort = threading.Event()
    _node, thread, result = _start_job(make_node, abort)
    supervisor = make_node("supervisor")
    states = supervisor.publisher(topics.SUPERVISOR_STATE)
    stops = make_node("bridge").subscribe(topics.MOTION_STOP)
    time.sleep(0.3)
    _states(states, 0, "idle", 0.4)
    time.sleep(4 * SUPERVISOR_SILENT_S)  # silent, still before episode 1
    assert thread.is_alive(), result
    abort.set()
    thread.join(5.0)
    assert result["job"].message == "test over"
    assert wait_until(lambda: stops.latest() is not None, 2.0)
    assert stops.latest().msg.reason == "protective stop: test over"  # only the abort's own stop


def test_a_silence_in_an_episode_is_a_protective_stop_by_the_launcher(make_node):
    abort = threading.Event()
    _node, thread, result = _start_job(make_node, abort)
    supervisor = make_node("supervisor")
    states = supervisor.publisher(topics.SUPERVISOR_STATE)
    stops = make_node("bridge").subscribe(topics.MOTION_STOP)
    time.sleep(0.3)
    _states(states, 1, "reach", 0.4)
    thread.join(5.0)
    abort.set()
    assert not thread.is_alive()
    job = result["job"]
    assert not job.ok and job.message.startswith("supervisor: silent: no supervisor/state for ")
    silent_s = float(re.search(r"for ([0-9.]+) s", job.message).group(1))
    assert silent_s > SUPERVISOR_SILENT_S  # the verdict's own measure of the silence
    assert wait_until(lambda: stops.latest() is not None, 2.0)
    stop = stops.latest()
    assert stop.msg.protective and "supervisor: silent" in stop.msg.reason
