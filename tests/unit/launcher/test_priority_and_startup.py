"""Per-service CPU niceness (profile → child process) and the start-up time report."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import psutil
import pytest

from services.launcher.core import format_startup_times, startup_times_s
from services.launcher.processes import Child
from services.launcher.checks import check_niced_services_are_report_only
from services.runtime.errors import ProfileError
from services.runtime.profile import load_profile_file

SAFETY_SERVICES = {"bridge", "motion", "gripper", "supervisor", "fake_baxter"}
#: Only report-only services are niced (a silent critical service is a protective stop).
EXPECTED_NICE = {"recorder": 10, "planner": 0, "tracker": 0, "kinect": 0}


def _profile(tmp_path: Path, service_table: str) -> Path:
    path = tmp_path / "p.toml"
    path.write_text('[bus]\nendpoint = "tcp/127.0.0.1:7447"\n\n' + service_table)
    return path


@pytest.mark.parametrize("value", [0, 7, 19])
def test_nice_in_range_is_read(tmp_path, value):
    profile = load_profile_file(_profile(tmp_path, f'[services.planner]\nnice = {value}\n'))
    assert profile.service("planner").nice == value


def test_nice_defaults_to_zero(tmp_path):
    assert load_profile_file(_profile(tmp_path, "[services.planner]\n")).service("planner").nice == 0


@pytest.mark.parametrize("value", ["-1", "20", "2.5", '"5"', "true"])
def test_bad_nice_is_one_line_naming_the_key(tmp_path, value):
    with pytest.raises(ProfileError) as info:
        load_profile_file(_profile(tmp_path, f"[services.planner]\nnice = {value}\n"))
    message = str(info.value)
    assert "services.planner.nice" in message and "0" in message and "19" in message
    assert "\n" not in message


def test_a_safety_service_may_not_be_niced(tmp_path):
    with pytest.raises(ProfileError, match=r"services\.motion\.nice = 3.*safety service"):
        load_profile_file(_profile(tmp_path, "[services.motion]\nsafety = true\nnice = 3\n"))


_SUPERVISED = '[services.supervisor]\n[services.supervisor.config.watch]\nrecorder = "report"\n'


def _checked(path):
    """The profile at `path` as `handover-up` takes it: loaded, then the launcher's nice check."""
    profile = load_profile_file(path)
    check_niced_services_are_report_only(profile)
    return profile


def test_a_service_the_supervisor_watches_as_critical_may_not_be_niced(tmp_path):
    with pytest.raises(ProfileError) as info:
        _checked(_profile(tmp_path, "[services.tracker]\nnice = 5\n" + _SUPERVISED))
    message = str(info.value)
    assert "services.tracker.nice = 5" in message and "critical" in message
    assert 'services.supervisor.config.watch.tracker = "report"' in message and "\n" not in message


def test_a_report_only_service_may_be_niced(tmp_path):
    profile = _checked(_profile(tmp_path, "[services.recorder]\nnice = 10\n[services.tracker]\nnice = 5\n"
                                + _SUPERVISED + 'tracker = "report"\n'))
    assert profile.service("recorder").nice == 10 and profile.service("tracker").nice == 5


def test_the_default_watch_table_lets_only_the_recorder_be_niced(tmp_path):
    assert _checked(_profile(tmp_path, "[services.recorder]\nnice = 10\n[services.supervisor]\n"
                             )).service("recorder").nice == 10
    with pytest.raises(ProfileError, match=r"services\.planner\.nice = 2"):
        _checked(_profile(tmp_path, "[services.planner]\nnice = 2\n[services.supervisor]\n"))


def test_another_bad_supervisor_key_does_not_switch_the_check_off(tmp_path):
    """`episodes = -1` is the supervisor's to reject (its CLI may override it); the niced
    tracker is still refused."""
    with pytest.raises(ProfileError, match=r"services\.tracker\.nice = 5"):
        _checked(_profile(tmp_path, "[services.tracker]\nnice = 5\n[services.supervisor]\n"
                          "[services.supervisor.config]\nepisodes = -1\n"))


def test_a_bad_watch_table_is_left_to_the_supervisor(tmp_path):
    profile = _checked(_profile(tmp_path, "[services.tracker]\nnice = 5\n" + _SUPERVISED
                                + 'tracker = "sometimes"\n'))
    assert profile.service("tracker").nice == 5


@pytest.mark.parametrize("name", ["sim", "baxter", "baxter_fake", "multihost"])
def test_deploy_profiles_keep_safety_services_at_full_priority(name):
    profile = load_profile_file(name)
    for spec in profile.services:
        if spec.safety or spec.name in SAFETY_SERVICES:
            assert spec.nice == 0, spec.name
        else:
            assert spec.nice == EXPECTED_NICE[spec.name], spec.name


def test_child_starts_with_the_requested_niceness():
    base = os.nice(0)
    want = min(base + 6, 19)  # niceness stops at 19 (a test run under `nice` starts higher)
    if want == base:
        pytest.skip("this test runs at nice 19 already: no lower priority to give a child")
    child = Child("sleeper", [sys.executable, "-c", "import time; time.sleep(30)"], 8, nice=want)
    child.start()
    try:
        assert psutil.Process(child.pid).nice() == want
    finally:
        child.signal(9)
        child.wait(5.0)


def test_child_is_never_started_below_the_launchers_niceness():
    base = os.nice(0)
    child = Child("sleeper", [sys.executable, "-c", "import time; time.sleep(30)"], 8, nice=0)
    child.start()
    try:
        assert psutil.Process(child.pid).nice() == base
    finally:
        child.signal(9)
        child.wait(5.0)


def test_startup_times_count_from_each_spawn_to_its_first_token():
    started = {"recorder": 10.0, "motion": 10.5, "bridge": 10.6}
    events = [
        (9.0, "motion", True),     # a token from before this spawn (an older process): ignored
        (9.5, "motion", False),
        (10.2, "recorder", True),
        (12.1, "motion", True),
        (12.4, "motion", False),   # later changes do not move the first-alive time
        (12.9, "motion", True),
        (11.0, "observer", True),  # not a child of the launcher
    ]
    times = startup_times_s(started, events)
    assert times == pytest.approx({"recorder": 0.2, "motion": 1.6})
    assert "bridge" not in times
    assert format_startup_times(started, events) == "motion 1.60 s, recorder 0.20 s"


def test_startup_line_lists_the_slowest_first():
    now = time.monotonic()
    started = {"a": now, "b": now, "c": now}
    events = [(now + 0.3, "a", True), (now + 2.0, "b", True), (now + 1.0, "c", True)]
    assert format_startup_times(started, events) == "b 2.00 s, c 1.00 s, a 0.30 s"


def test_router_skips_the_scouting_delay_unless_the_profile_sets_one():
    from services.launcher.core import router_zenoh_overrides

    profile_overrides = {"transport": {"link": {"tx": {"lease": 5000}}}}
    merged = router_zenoh_overrides(profile_overrides)
    assert merged == {"transport": {"link": {"tx": {"lease": 5000}}}, "scouting": {"delay": 0}}
    assert profile_overrides == {"transport": {"link": {"tx": {"lease": 5000}}}}  # not mutated
    assert router_zenoh_overrides({"scouting": {"delay": 200}}) == {"scouting": {"delay": 200}}


def test_router_config_keeps_scouting_off_with_the_delay_removed():
    from dataclasses import replace

    from services.launcher.core import router_zenoh_overrides
    from services.runtime.zenoh_config import zenoh_config_dict

    profile = load_profile_file("sim")
    conf = zenoh_config_dict(replace(profile, zenoh_overrides=router_zenoh_overrides(profile.zenoh_overrides)),
                             "router")
    assert conf["scouting"] == {"multicast": {"enabled": False}, "gossip": {"enabled": False}, "delay": 0}
    assert conf["listen"]["endpoints"] == [profile.endpoint] and conf["connect"]["endpoints"] == []


def test_motion_loads_baxter_without_meshes_but_with_every_joint_and_frame():
    """Motion's PlaCo model is the URDF minus <visual>/<collision> (no mesh is read): the same
    links, joints, limits and inertias as the file, so the kinematics are unchanged."""
    import xml.etree.ElementTree as ET

    from handover_model.robots import baxter
    from services.motion.ik import kinematic_urdf_text

    full = ET.parse(baxter.urdf_path()).getroot()
    stripped = ET.fromstring(kinematic_urdf_text())
    assert "<mesh" not in kinematic_urdf_text() and full.find(".//mesh") is not None
    assert not stripped.findall(".//visual") and not stripped.findall(".//collision")

    def describe(root):
        joints = {j.get("name"): (j.get("type"), ET.tostring(j.find("limit")) if j.find("limit") is not None else b"")
                  for j in root.iter("joint")}
        inertias = {link.get("name"): ET.tostring(link.find("inertial")) if link.find("inertial") is not None else b""
                    for link in root.iter("link")}
        return joints, inertias

    assert describe(stripped) == describe(full)
    assert len(list(stripped.iter("joint"))) >= 7 and set(baxter.RIGHT_ARM_JOINTS) <= {
        j.get("name") for j in stripped.iter("joint")}
