"""The bridge's sim backend with the contact plant, as a real process."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bus_schema import topics
from services.bridge.config import parse_config
from services.bridge.errors import BridgeConfigError
from services.runtime.testing import ServiceProcess, wait_alive

pytestmark = pytest.mark.integration


def _run(bus, make_node, behaviour, grip_schedule, seconds=3.0):
    """Run the bridge with a receiver; grip_schedule(t) → grip command (N) or None."""
    profile, router = bus
    args = ["--receiver", behaviour, "--seed", "3", "--scenario", "transfer"]
    with ServiceProcess("services.bridge", profile, args) as bridge:
        wait_alive(router, profile, {"bridge"})
        node = make_node()
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=10_000)
        wrench = node.subscribe(topics.WRIST_WRENCH, queue_size=10_000)
        motion = node.subscribe(topics.OBJECT_MOTION, queue_size=10_000)
        grip = node.publisher(topics.GRIPPER_COMMAND)
        t0 = time.monotonic()
        while (t := time.monotonic() - t0) < seconds:
            force = grip_schedule(t)
            if force is not None:
                grip.put(grip_force_n=force)
            time.sleep(0.01)
        assert bridge.proc.poll() is None, bridge.log_text()
        return [r.msg for r in truth.drain()], [r.msg for r in wrench.drain()], [r.msg for r in motion.drain()]


def test_taking_with_an_open_gripper_ends_in_the_receivers_hand(bus, make_node):
    truth, wrench, motion = _run(bus, make_node, "taking", lambda t: 0.0 if t > 1.8 else None)
    assert 250 <= len(wrench) <= 330 and 250 <= len(motion) <= 330  # the sensors: 100 Hz
    # sim/truth: every change at once (100 Hz while the scene moves), a copy every 0.1 s at rest.
    assert 30 <= len(truth) <= 330
    def values(m):
        return tuple(getattr(m, f) for f in m.__struct_fields__ if f not in ("seq", "stamp_ns", "source"))
    moving = sum(values(a) != values(b) for a, b in zip(truth, truth[1:], strict=False))
    assert moving >= 100, moving  # the transfer: the object slides, the receiver pulls
    for a, b in zip(truth, truth[1:], strict=False):
        if values(a) == values(b):  # an unchanged copy comes 0.1 s after the last one
            assert (b.stamp_ns - a.stamp_ns) * 1e-9 > 0.085, (a, b)
    last = truth[-1]
    assert last.held_by == "receiver" and not last.dropped
    assert last.grip_force_n == 0.0  # the command reached the actuator
    # The receiver really pulled (the wrist felt it along x) before the release.
    assert max(abs(w.force_n[0]) for w in wrench) > 0.5
    # Object position in the base frame is near the tool, not fallen away.
    assert np.linalg.norm(np.subtract(last.object_position_m, last.tool_position_m)) < 0.5


def test_grip_command_is_followed_through_the_spring_actuator(bus, make_node):
    truth, _, _ = _run(bus, make_node, "absent", lambda t: 30.0, seconds=2.0)
    forces = np.array([m.grip_force_n for m in truth])
    assert forces[0] < 20.0  # starts at the initial 10 N
    assert forces[-1] == pytest.approx(30.0, abs=1.0)  # arrives, with the actuator's delay
    assert not truth[-1].dropped and truth[-1].held_by == "gripper"


def test_dropping_receiver_against_a_weak_constant_grip_drops_the_object(bus, make_node):
    truth, _, _ = _run(bus, make_node, "dropping", lambda t: None, seconds=3.0)
    assert truth[-1].dropped and truth[-1].held_by == "none"
    assert max(m.slip_m for m in truth) > 0.1


def test_contact_config_errors_name_the_key():
    with pytest.raises(BridgeConfigError, match="behaviour"):
        parse_config({"contact": {"enabled": True, "behaviour": "juggling"}})
    with pytest.raises(BridgeConfigError, match="object_mass_kg"):
        parse_config({"contact": {"object_mass_kg": -1.0}})
    from services.bridge.backend import make_backend

    cfg = parse_config({"contact": {"enabled": True, "receiver": {"no_such_parameter": 1.0}}})
    with pytest.raises(BridgeConfigError, match="receiver"):
        make_backend("sim", contact=cfg.contact)
