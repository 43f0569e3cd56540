"""Who is lost or silent: the watchdog's rules with hand-made timelines."""

from __future__ import annotations

from services.supervisor.watchdog import Watchdog


def make():
    return Watchdog(["bridge", "gripper", "recorder"], heartbeat_timeout_s=0.25, stream_timeout_s=0.15,
                    streams={"robot/joint_state": "bridge"})


def test_nothing_is_judged_before_a_service_was_seen():
    w = make()
    assert w.check(100.0) == [] and w.missing() == ["bridge", "gripper", "recorder"]


def test_a_lost_liveliness_token_is_reported_once_with_when_it_went():
    w = make()
    for s in w.services:
        w.liveliness(s, True, 1.0)
    w.liveliness("gripper", False, 5.00)
    faults = w.check(5.01)
    assert [(f.service, f.what) for f in faults] == [("gripper", "lost")]
    assert faults[0].since_s == 5.00 and "gripper" in faults[0].text()
    assert w.check(5.02) == []  # once


def test_a_silent_heartbeat_is_noticed_after_the_timeout_and_not_before():
    w = make()
    w.liveliness("recorder", True, 0.0)
    w.heartbeat("recorder", 10.00)
    assert w.check(10.24) == []
    (fault,) = w.check(10.26)
    assert fault.what == "silent" and "no heartbeat for 0.260 s" in fault.detail
    w.heartbeat("recorder", 10.40)  # SIGCONT: it beats again, and may be reported again later
    assert w.check(10.41) == []
    assert [f.service for f in w.check(10.70)] == ["recorder"]


def test_a_frozen_stream_makes_its_owner_silent():
    w = make()
    w.liveliness("bridge", True, 0.0)
    w.heartbeat("bridge", 1.0)
    w.stream("robot/joint_state", 1.00)
    w.heartbeat("bridge", 1.14)
    (fault,) = w.check(1.16)
    assert fault.service == "bridge" and "robot/joint_state" in fault.detail


def test_a_restarted_service_is_judged_afresh():
    w = make()
    w.liveliness("recorder", True, 0.0)
    w.liveliness("recorder", False, 1.0)
    assert len(w.check(1.01)) == 1
    w.liveliness("recorder", True, 2.0)
    assert w.check(2.01) == [] and w.all_alive() is False  # bridge and gripper never came


def test_a_report_only_service_has_its_own_heartbeat_timeout():
    w = Watchdog(["bridge", "recorder"], heartbeat_timeout_s=0.25, stream_timeout_s=0.15,
                 heartbeat_timeouts_s={"recorder": 0.75})
    for s in w.services:
        w.liveliness(s, True, 0.0)
        w.heartbeat(s, 10.0)
    # 0.4 s without a beat: the critical bridge is silent, the recorder (a long write) is not.
    assert [f.service for f in w.check(10.4)] == ["bridge"]
    assert w.check(10.74) == []
    (fault,) = w.check(10.76)
    assert fault.service == "recorder" and "no heartbeat for 0.760 s" in fault.detail


def test_ten_hz_beats_on_one_host_a_stopped_service_is_silent_130_ms_after_its_last_beat():
    """One host: beats every 0.1 s; the kernel's word that a process is stopped makes it
    silent once a beat is 30 ms overdue; a running one gets the default 0.25 s time-out."""
    from services.runtime.node import HEARTBEAT_PERIOD_S, MULTIHOST_HEARTBEAT_PERIOD_S
    from services.supervisor.watchdog import default_heartbeat_timeout_s, judging_for_beats
    from tests.unit.runtime.test_sched import FixedExcuser

    assert (HEARTBEAT_PERIOD_S, MULTIHOST_HEARTBEAT_PERIOD_S) == (0.1, 0.05)
    assert abs(default_heartbeat_timeout_s(0.1) - 0.25) < 1e-12  # one host: a beat may be 0.15 s late
    assert abs(default_heartbeat_timeout_s(0.05) - 0.2) < 1e-12  # across hosts: as before
    excuser = FixedExcuser(None)
    w = Watchdog(["motion", "planner"], heartbeat_timeout_s=default_heartbeat_timeout_s(0.1), excuser=excuser,
                 **judging_for_beats(0.1))
    for name in ("motion", "planner"):
        w.liveliness(name, True, 0.0)
        w.heartbeat(name, 10.0)
    excuser.stopped_services = {"motion"}
    assert w.check(10.10) == [] and excuser.noted == []  # one period: on time, nothing noted
    assert w.check(10.12) == [] and {s for s, _ in excuser.noted} == {"motion", "planner"}  # 10 ms overdue: noted
    (fault,) = w.check(10.135)
    assert fault.service == "motion" and "stopped" in fault.detail  # stopped: silent at 0.135 s
    assert w.check(10.245) == []  # planner runs: a beat 0.145 s late is still not judged
    (late,) = w.check(10.26)
    assert late.service == "planner" and "no heartbeat for 0.260 s" in late.detail


def test_the_profile_sets_the_heartbeat_period():
    from types import SimpleNamespace

    from services.runtime.node import heartbeat_period_s

    assert heartbeat_period_s(SimpleNamespace(allow_non_loopback=False)) == 0.1
    assert heartbeat_period_s(SimpleNamespace(allow_non_loopback=True)) == 0.05


def test_a_heartbeat_time_out_shorter_than_a_beat_is_refused_in_one_line():
    import pytest

    from services.supervisor.errors import SupervisorConfigError
    from services.supervisor.watchdog import resolve_heartbeat_timeout_s

    assert abs(resolve_heartbeat_timeout_s(None, 0.1) - 0.25) < 1e-12
    assert resolve_heartbeat_timeout_s(0.4, 0.1) == 0.4
    assert abs(resolve_heartbeat_timeout_s(None, 0.05) - 0.2) < 1e-12  # across hosts: 0.2 s as before
    with pytest.raises(SupervisorConfigError, match=r"heartbeat_timeout_s = 0.12 s is shorter than one heartbeat"):
        resolve_heartbeat_timeout_s(0.12, 0.1)
