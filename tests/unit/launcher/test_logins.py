"""Per-run logins (services/launcher/logins.py): private files, one login per service, and a
deny-by-default list that gives each service its own keys only."""

from __future__ import annotations

import stat

import pytest

from services.launcher.logins import (OBSERVER, LoginsError, create_run_logins, run_access_control,
                                      start_run_logins)
from services.runtime.profile import load_profile_file
from services.runtime.zenoh_config import zenoh_config_dict


def test_each_user_gets_a_private_file_and_the_router_every_line(tmp_path):
    logins = create_run_logins(tmp_path / "bus", ["bridge", "gripper", OBSERVER])
    assert stat.S_IMODE((tmp_path / "bus").stat().st_mode) == 0o700
    lines = {}
    for user in ("bridge", "gripper", OBSERVER):
        text = logins.user_file(user).read_text()
        assert stat.S_IMODE(logins.user_file(user).stat().st_mode) == 0o600
        assert text.startswith(f"{user}:") and len(text.strip()) > len(user) + 20
        lines[user] = text
    assert sorted(logins.dictionary.read_text().splitlines()) == sorted(t.strip() for t in lines.values())
    assert len({t.split(":")[1] for t in lines.values()}) == 3  # three different passwords
    with pytest.raises(LoginsError, match="exists already"):
        create_run_logins(tmp_path / "bus", ["bridge"])
    logins.remove()
    assert not (tmp_path / "bus").exists()


def test_the_list_gives_each_service_its_own_keys(tmp_path):
    acl = run_access_control(["bridge", "supervisor", "planner", "recorder"], "handover")
    conf = acl.zenoh_dict("handover/v1")
    rules = {r["id"]: r for r in conf["rules"]}
    assert conf["default_permission"] == "deny"
    assert "handover/v1/motion/stop" in rules["supervisor_publish"]["key_exprs"]
    assert all("motion/stop" not in k for k in rules["planner_publish"]["key_exprs"])
    # The bridge stops the arm itself when the supervisor dies mid-episode, and says so.
    assert "handover/v1/motion/stop" in rules["bridge_publish"]["key_exprs"]
    assert rules["planner_publish"]["key_exprs"] == ["handover/v1/planner/transfer",
                                                     "handover/v1/sim/clock_ready/planner",
                                                     "handover/v1/runtime/heartbeat/planner"]
    assert rules["recorder_publish"]["key_exprs"] == ["handover/v1/runtime/heartbeat/recorder"]
    assert "observer_subscribe" in rules and rules["observer_publish"]["key_exprs"] == [
        "handover/v1/runtime/heartbeat/observer"]
    assert "handover/v1/robot/joint_command" not in rules["launcher_publish"]["key_exprs"]
    assert "handover/v1/motion/stop" in rules["launcher_publish"]["key_exprs"]  # its own protective stop
    demo = {r["id"]: r for r in run_access_control(["bridge"], "demo").zenoh_dict("handover/v1")["rules"]}
    assert "handover/v1/robot/joint_command" in demo["launcher_publish"]["key_exprs"]
    with pytest.raises(LoginsError, match="'kinect_v2'"):
        run_access_control(["kinect_v2"], "handover")
    # The Baxter profiles: the bridge sends the robot's ROS 1 commands, the fake Baxter its state.
    ros = {r["id"]: r for r in run_access_control(["bridge", "fake_baxter"], "handover").zenoh_dict("handover/v1")[
        "rules"]}
    assert "**/robot/limb/right/joint_command" in ros["bridge_publish"]["key_exprs"]
    assert "**/robot/limb/right/joint_command" not in ros["fake_baxter_publish"]["key_exprs"]
    assert "**/robot/joint_states" in ros["fake_baxter_publish"]["key_exprs"]


def test_the_default_profile_runs_with_logins_and_the_router_checks_them(tmp_path, monkeypatch):
    monkeypatch.delenv("HANDOVER_BUS_CREDENTIALS", raising=False)
    profile = load_profile_file("sim")
    assert profile.logins == "per-run" and profile.auth is None
    logins, bus_profile, acl = start_run_logins(profile, ["bridge"], tmp_path, "r", "handover")
    from dataclasses import replace

    router = zenoh_config_dict(replace(bus_profile, access_control=acl), "router")
    assert router["transport"]["auth"]["usrpwd"]["dictionary_file"] == str(logins.dictionary)
    assert router["access_control"]["default_permission"] == "deny"
    # A service of the run finds its own login through the environment.
    monkeypatch.setenv("HANDOVER_BUS_CREDENTIALS", str(logins.user_file("bridge")))
    child = load_profile_file("sim")
    password = logins.user_file("bridge").read_text().split(":")[1].strip()
    assert child.auth is not None and child.auth.password("bridge") == password



def test_the_keys_follow_each_services_set_up():
    """A tracker fed by the bus renders no Kinect; a bridge driving Baxter runs no simulation."""
    from services.runtime.profile import load_profile_file

    def grants(profile_name, services):
        acl = run_access_control(services, "handover", load_profile_file(profile_name)).zenoh_dict("handover/v1")
        return {r["id"]: r["key_exprs"] for r in acl["rules"]}

    sim = grants("sim", ["tracker", "bridge"])
    assert "handover/v1/perception/skeleton" in sim["tracker_publish"]
    assert "handover/v1/sim/truth" in sim["bridge_publish"]
    bus_fed = grants("multihost", ["tracker"])  # sensor = "bus": a Kinect driver publishes the skeleton
    assert "handover/v1/perception/skeleton" not in bus_fed["tracker_publish"]
    fake = grants("baxter_fake", ["tracker", "bridge", "fake_baxter"])
    assert "handover/v1/sim/truth" not in fake["bridge_publish"]
    assert "handover/v1/sim/truth" in fake["fake_baxter_publish"]
    # sensor = "ros1": the tracker publishes the skeleton and depth it converts, no Kinect truth.
    assert {"handover/v1/perception/skeleton", "handover/v1/perception/depth"} <= set(fake["tracker_publish"])
    assert "handover/v1/sim/kinect_truth" not in fake["tracker_publish"]
    assert {"**/tf", "**/camera/depth/image_raw", "**/camera/depth/camera_info"} <= set(fake["fake_baxter_publish"])
