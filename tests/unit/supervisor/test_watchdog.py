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
