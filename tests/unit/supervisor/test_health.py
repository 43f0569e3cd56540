"""The supervisor's health watch: what a fault means and when its own loop was too late."""

from __future__ import annotations

import pytest

from bus_schema import topics
from services.supervisor.config import SupervisorConfig
from services.supervisor.errors import SupervisorConfigError
from services.supervisor.health import SELF_STALL_REPORT_S, SELF_STALL_S, HealthWatch, Stall

SERVICES = ["bridge", "gripper", "motion", "recorder"]
BEAT_S = 0.1


class FakeStarvation:
    """Never excuses; remembers the process ids heard and explains every silence alike."""

    def __init__(self):
        self.pids = {}

    def heard(self, service, pid):
        self.pids[service] = pid

    def explain(self, service):
        return f"{service}: not starved"

    def note(self, service, now_s, quiet_since_s=None):
        pass

    def excuse(self, service, now_s):
        return None

    def tick(self, now_s):
        pass

    def exited(self):
        return set()

    def stopped(self, service, now_s):
        return False

    def revived(self, service):
        pass


def watch(starvation=None, **config):
    health = HealthWatch(SERVICES, SupervisorConfig(**config), BEAT_S, starvation)
    for name in SERVICES:
        health.liveliness(name, True, 0.0)
        health.heartbeat(name, 1000 + len(name), 10.0)
    return health


def test_a_lost_critical_service_is_critical_and_a_lost_report_only_one_is_not():
    health = watch()
    health.liveliness("gripper", False, 10.02)
    health.liveliness("recorder", False, 10.02)
    reports = {r.fault.service: r for r in health.check(10.03)}
    assert reports["gripper"].critical and not reports["recorder"].critical
    assert reports["gripper"].starvation == "n/a"  # a lost process is no question of starvation
    fields = reports["gripper"].log_fields()
    assert list(fields) == ["service", "what", "detail", "critical", "notice_latency_s", "starvation"]
    assert fields["what"] == "lost" and fields["notice_latency_s"] == pytest.approx(0.01)


def test_a_silence_is_explained_by_the_starvation_judge_and_heartbeats_tell_it_the_pid():
    starvation = FakeStarvation()
    health = watch(starvation)
    assert starvation.pids["bridge"] == 1006
    for name in ("gripper", "motion", "recorder"):
        health.heartbeat(name, 1, 10.2)
    (report,) = health.check(10.27)  # the bridge's last beat 0.27 s ago: silent after 0.25 s
    assert report.fault.service == "bridge" and report.fault.what == "silent"
    assert report.critical and report.starvation == "bridge: not starved"


def test_a_report_only_service_is_silent_only_after_its_own_longer_timeout():
    health = watch(report_heartbeat_timeout_s=0.75)
    for name in ("bridge", "gripper", "motion"):
        health.heartbeat(name, 1, 10.5)
    assert health.check(10.6) == []  # the recorder's 0.6 s silence is not yet a fault
    for name in ("bridge", "gripper", "motion"):
        health.heartbeat(name, 1, 10.7)
    assert [r.fault.service for r in health.check(10.8)] == ["recorder"]


def test_the_watched_streams_of_the_services_that_touch_the_robot():
    health = watch(stream_timeout_s=0.2)
    health.stream(topics.JOINT_STATE.suffix, 10.0)
    health.stream(topics.MOTION_STATUS.suffix, 10.0)  # not watched: motion is judged by its heartbeat
    for name in SERVICES:
        health.heartbeat(name, 1, 10.2)
    (report,) = health.check(10.21)
    assert report.fault.service == "bridge" and topics.JOINT_STATE.suffix in report.fault.detail


def test_a_heartbeat_timeout_shorter_than_a_beat_is_refused():
    with pytest.raises(SupervisorConfigError, match="heartbeat_timeout_s"):
        HealthWatch(SERVICES, SupervisorConfig(heartbeat_timeout_s=0.12), BEAT_S, None)


def test_a_late_loop_settles_only_when_someone_looks_silent_and_is_reported_when_very_late():
    health = watch()
    for name in SERVICES:
        health.heartbeat(name, 1, 10.0)
    assert health.stall(SELF_STALL_S + 0.01, 10.1) is None  # late, but nobody looks silent
    stall = health.stall(SELF_STALL_S + 0.01, 10.3)  # every heartbeat 0.3 s old
    assert stall == Stall(SELF_STALL_S + 0.01, settle=True) and stall.late_ms == 60
    assert stall.message() == ("supervisor loop was 60 ms late: taking queued messages in before judging "
                               "freshness")
    assert health.check(10.3) != []  # the stall check only looked: the faults are still to report
    quiet = watch()
    for name in SERVICES:
        quiet.heartbeat(name, 1, 10.0)
    report = quiet.stall(SELF_STALL_REPORT_S + 0.05, 10.1)
    assert report == Stall(SELF_STALL_REPORT_S + 0.05, settle=False)
    assert report.message() == "supervisor loop was 250 ms late (starved of CPU?); no service looked silent"
    assert quiet.stall(SELF_STALL_S - 0.01, 10.4) is None  # on time: nothing, whoever looks silent
