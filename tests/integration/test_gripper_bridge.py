"""The gripper service (recommended controller SG) closing the loop with the bridge's contact
plant, as real processes; outcomes read from sim truth."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from bus_schema import topics
from services.runtime.profile import DEPLOY_DIR
from services.runtime.testing import ServiceProcess, wait_alive

pytestmark = pytest.mark.integration


def _profile(tmp_path: Path, profile, receiver: dict) -> object:
    text = (DEPLOY_DIR / "sim.toml").read_text()
    text += "\n[services.bridge.config.contact.receiver]\n" + "".join(f"{k} = {v}\n" for k, v in receiver.items())
    path = tmp_path / "gripper_bridge.toml"
    path.write_text(text)
    from services.runtime.profile import load_profile_file

    return load_profile_file(path).with_bus(endpoint=profile.endpoint)


def _handover(bus, make_node, tmp_path, behaviour, receiver, seconds=4.5):
    base, router = bus
    profile = _profile(tmp_path, base, {"reach_start_s": 0.8, **receiver})
    with ServiceProcess("services.gripper", profile, ["--controller", "SG"]) as gripper:
        wait_alive(router, profile, {"gripper"})
        node = make_node()
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=10_000)
        releases = node.subscribe(topics.GRIPPER_RELEASE)
        states = node.subscribe(topics.GRIPPER_STATE, queue_size=10_000)
        with ServiceProcess("services.bridge", profile, ["--receiver", behaviour, "--seed", "3"]) as bridge:
            wait_alive(router, profile, {"bridge"})
            time.sleep(seconds)
            assert bridge.proc.poll() is None, bridge.log_text()
        assert gripper.proc.poll() is None, gripper.log_text()
        return [r.msg for r in truth.drain()], [r.msg for r in releases.drain()], [r.msg for r in states.drain()]


def test_taking_receiver_gets_the_object(bus, make_node, tmp_path):
    truth, releases, states = _handover(bus, make_node, tmp_path, "taking", {})
    assert len(truth) > 300
    assert not any(t.dropped for t in truth)
    assert truth[-1].held_by == "receiver"
    assert len(releases) == 1 and releases[0].controller == "SG"
    assert states[-1].released and states[-1].mode == "release"


def test_gentle_dropping_receiver_does_not_make_it_fall(bus, make_node, tmp_path):
    truth, releases, states = _handover(bus, make_node, tmp_path, "dropping", {"grasp_strength_n": 6.0})
    assert len(truth) > 300
    assert not any(t.dropped for t in truth)
    assert truth[-1].held_by == "gripper"
    assert releases == [] and not states[-1].released
