"""The gripper service as a real process on a loopback bus, fed by a test-side publisher of
synthetic wrist-wrench and object-motion messages."""

from __future__ import annotations

import time

import pytest

from bus_schema import topics
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration
W = 0.23 * 9.81
REST_FS1_N = 10 * W - 15  # α F_sy − F_margin: FS1's fixed point at rest


@pytest.fixture
def gripper(bus):
    profile, router = bus
    with ServiceProcess("services.gripper", profile, args=["--controller", "FS1", "--rate-hz", "100"]) as proc:
        wait_alive(router, profile, {"gripper"})
        yield proc


def _stream(wrench, motion, seconds, fx=0.0, fy=W, rate_hz=100.0):
    """Stream sensor messages; return the wall-clock ns just after the last put."""
    end = time.monotonic() + seconds
    last_put_ns = time.time_ns()
    while time.monotonic() < end:
        wrench.put(force_n=(fx, fy, 0.0))
        motion.put(displacement_counts=(0, 0), counts_per_m=15748.0, dt_s=1.0 / rate_hz)
        last_put_ns = time.time_ns()
        time.sleep(1.0 / rate_hz)
    return last_put_ns


def test_holds_without_sensors_then_follows_fs1_then_releases_once(gripper, make_node):
    node = make_node()
    states = node.subscribe(topics.GRIPPER_STATE, queue_size=2000)
    commands = node.subscribe(topics.GRIPPER_COMMAND, queue_size=2000)
    releases = node.subscribe(topics.GRIPPER_RELEASE)
    wrench, motion = node.publisher(topics.WRIST_WRENCH), node.publisher(topics.OBJECT_MOTION)
    assert wait_until(lambda: states.latest() is not None, 5.0)
    s = states.latest().msg
    assert s.mode == "hold" and not s.sensors_fresh and "never received" in s.reason
    # An unchanged hold command is repeated every 50 ms (services/runtime/repeat.py).
    assert wait_until(lambda: commands.latest() is not None, 0.5)
    assert commands.latest().msg.grip_force_n >= 10.0  # the hold floor: never open without data

    _stream(wrench, motion, 0.5)
    c = commands.latest().msg
    assert c.mode == "grasp" and c.grip_force_n == pytest.approx(REST_FS1_N, abs=1e-6)
    assert c.position_m == pytest.approx(REST_FS1_N / 500.0, abs=1e-9)  # eq 3.21, k = 5 N/cm
    assert releases.latest() is None

    _stream(wrench, motion, 0.6, fx=4.0, fy=0.3)  # the receiver takes the weight and pulls
    assert wait_until(lambda: releases.latest() is not None, 2.0)
    _stream(wrench, motion, 0.3, fx=0.0, fy=W)  # the load comes back: latched open
    assert len(releases.drain()) == 1
    assert releases.latest().msg.controller == "FS1"
    assert commands.latest().msg.grip_force_n == 0.0
    assert states.latest().msg.released


def test_silent_sensors_hold_and_never_open(gripper, make_node):
    node = make_node()
    states = node.subscribe(topics.GRIPPER_STATE, queue_size=5000)
    commands = node.subscribe(topics.GRIPPER_COMMAND, queue_size=5000)
    wrench, motion = node.publisher(topics.WRIST_WRENCH), node.publisher(topics.OBJECT_MOTION)
    assert wait_until(lambda: states.latest() is not None, 5.0)
    _stream(wrench, motion, 0.4)
    last_put_ns = _stream(wrench, motion, 0.1, fx=2.0)  # pulled a little: FS1 eases off
    last_cmd = commands.latest().msg.grip_force_n
    time.sleep(0.4)
    held = [r for r in commands.drain() if r.msg.mode == "hold" and r.msg.stamp_ns > last_put_ns]
    assert held, "no hold after the sensors went silent"
    # Judged on the gripper's own stamps (same host clock), not the test's receive time: the
    # 50 ms staleness time-out, a 10 ms tick and a loaded machine's slack.
    hold_after_s = (held[0].msg.stamp_ns - last_put_ns) * 1e-9
    assert hold_after_s <= 0.05 + 0.01 + 0.1, hold_after_s
    assert min(r.msg.grip_force_n for r in held) >= min(last_cmd, 10.0) and all(
        r.msg.grip_force_n >= last_cmd for r in held)
    assert "stale" in states.latest().msg.reason and not states.latest().msg.sensors_fresh


def test_undecodable_payloads_hold_and_are_reported(gripper, make_node):
    node = make_node()
    states = node.subscribe(topics.GRIPPER_STATE, queue_size=2000)
    wrench, motion = node.publisher(topics.WRIST_WRENCH), node.publisher(topics.OBJECT_MOTION)
    _stream(wrench, motion, 0.3)
    end = time.monotonic() + 0.4
    while time.monotonic() < end:
        wrench.put_raw(b"\xff\x00garbage")
        motion.put(displacement_counts=(0, 0), counts_per_m=15748.0, dt_s=0.01)
        time.sleep(0.01)
    s = states.latest().msg
    assert s.mode == "hold" and "undecodable" in s.reason
    _stream(wrench, motion, 0.3)  # good data again: the service goes on
    assert states.latest().msg.mode == "grasp" and gripper.proc.poll() is None


def _main_thread_wakes(pid: int) -> int:
    """Voluntary context switches of process `pid`'s main thread so far (each a sleep ended)."""
    with open(f"/proc/{pid}/task/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("voluntary_ctxt_switches"))


def test_supervisor_states_wake_the_gripper_only_when_its_episode_or_grip_request_changes(gripper, make_node):
    """States at 100 Hz that say nothing new to the gripper leave its main thread at its 20 Hz
    hold ticks; a changed grip request still reaches it (the command opens at once)."""
    node = make_node("supervisor")
    states = node.publisher(topics.SUPERVISOR_STATE)
    commands = make_node().subscribe(topics.GRIPPER_COMMAND, queue_size=2000)
    assert wait_until(lambda: commands.latest() is not None, 5.0)
    for _ in range(20):  # the gripper takes the request in
        states.put(phase="pick", episode_id=1, grip_request="carry")
        time.sleep(0.01)
    before = _main_thread_wakes(gripper.pid)
    start = time.monotonic()
    while time.monotonic() < start + 2.0:
        states.put(phase="pick", episode_id=1, grip_request="carry")
        time.sleep(0.01)
    wakes = _main_thread_wakes(gripper.pid) - before
    # 2 s of hold ticks at 20 Hz: about 40 (a state waking the loop: 200 more).
    assert wakes < 120, wakes
    commands.drain()
    states.put(phase="done", episode_id=1, grip_request="open")
    assert wait_until(lambda: any(rx.msg.grip_force_n == 0.0 for rx in commands.drain()), 0.5)
