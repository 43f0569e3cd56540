"""The fault-run judge on hand-made records, and the fault windows of the runtime injection."""

from __future__ import annotations

from bus_schema.messages import EpisodeSummary, JointState, MotionGoal, MotionStop, SimTruth
from services.runtime.faults import ARM_DIR_ENV_VAR, FaultRule, FaultyPut, arm_file_name
from tests.faults.invariants import FaultPlan, Injection, RunRecord, judge

H = {"seq": 0, "stamp_ns": 0, "source": "t"}


def at(t_s):
    """A header stamped at `t_s` (the senders' clock; the judge orders motion checks by it)."""
    return {"seq": 0, "stamp_ns": int(round(t_s * 1e9)), "source": "t"}


def js(v, t_s=0.0):
    return JointState(**at(t_s), names=["a", "b"], position_rad=[0.0, 0.0], velocity_rad_s=[v, 0.0])


def record(speeds, stop_at=1.0, exit_code=1, service="motion", dropped_at=None):
    rec = RunRecord(receiver="absent")
    rec.injections = [Injection(FaultPlan("kill", service), at_s=0.9, at_wall_s=0.9, phase_seen_s=0.5)]
    rec.joints = [(0.01 * i, js(v, 0.01 * i)) for i, v in enumerate(speeds)]
    rec.truth = [(0.01 * i, SimTruth(**H, dropped=dropped_at is not None and 0.01 * i >= dropped_at))
                 for i in range(len(speeds))]
    rec.stops = [(stop_at, MotionStop(**at(stop_at), reason=f"protective stop: {service}: lost", protective=True))]
    rec.summaries = [(1.5, EpisodeSummary(**H, episode_id=1, outcome="protective_stop",
                                          reason=f"protective stop: {service}: process gone",
                                          faults=[f"{service}: process gone"]))]
    rec.exit_code, rec.exit_line = exit_code, f"[launcher] exit {exit_code}: {service} was killed by SIGKILL"
    return rec


def test_a_clean_protective_stop_passes_and_gives_its_stop_latency():
    speeds = [0.5] * 100 + [0.2, 0.05, 0.0] + [0.0] * 50  # braking ends at t = 1.02 s
    v = judge(record(speeds))
    assert v.ok, v.violations
    assert abs(v.stop_s["kill motion @ transfer"] - (1.02 - 0.9)) < 1e-9


def test_motion_after_the_stop_a_drop_and_a_wrong_exit_are_each_caught():
    speeds = [0.5] * 100 + [0.0] * 20 + [0.3] + [0.0] * 20
    v = judge(record(speeds, exit_code=0, dropped_at=1.3))
    text = "\n".join(v.violations)
    assert "arm moved after the protective stop: 0.300 rad/s" in text
    assert "object dropped" in text
    assert "launcher exit 0, expected 1" in text


def test_a_fault_that_nobody_names_is_a_violation():
    rec = record([0.0] * 150, service="planner")
    rec.summaries = [(1.5, EpisodeSummary(**H, episode_id=1, outcome="timeout", reason="no release"))]
    rec.exit_line = "[launcher] exit 1"
    v = judge(rec)
    assert any("not named" in x for x in v.violations)


def test_the_retract_after_a_release_is_allowed_but_moving_before_it_is_not():
    speeds = [0.4] * 100 + [0.0] * 50 + [0.5] * 20
    rec = record(speeds)
    rec.injections, rec.exit_code = [], 0
    rec.stops = [(1.0, MotionStop(**at(1.0), reason="release"))]
    rec.goals = [(1.5, MotionGoal(**at(1.5), goal_id="r", kind="retract"))]
    assert judge(rec).ok
    rec.goals = [(1.6, MotionGoal(**at(1.6), goal_id="r", kind="retract"))]
    assert any("before the retract" in x for x in judge(rec).violations)
    # The observer got the retract goal late (received at 1.7 s, sent at 1.5 s): the senders'
    # stamps decide, so this is no violation.
    rec.goals = [(1.7, MotionGoal(**at(1.5), goal_id="r", kind="retract"))]
    assert judge(rec).ok, judge(rec).violations


def test_an_armed_fault_acts_only_while_its_file_exists(tmp_path, monkeypatch):
    monkeypatch.setenv(ARM_DIR_ENV_VAR, str(tmp_path))
    sent: list[bytes] = []
    put = FaultyPut(sent.append, FaultRule("motion", "robot/joint_command", "drop", 1.0), seed=0)
    put(b"a")
    assert sent == [b"a"]  # not armed: passes
    (tmp_path / arm_file_name("motion", "robot/joint_command")).touch()
    put._armed_checked_s = -1.0
    put(b"b")
    assert sent == [b"a"] and put.dropped == 1
    (tmp_path / arm_file_name("motion", "robot/joint_command")).unlink()
    put._armed_checked_s = -1.0
    put(b"c")
    assert sent == [b"a", b"c"]


def test_an_arm_that_never_comes_to_rest_after_a_stop_is_caught():
    # Protective stop at 1.0 s; the arm keeps moving at 0.3 rad/s to the end (1.5 s of states).
    v = judge(record([0.5] * 100 + [0.3] * 150))
    assert any("never came to rest after the protective stop" in x and "moving at 0.300" in x
               for x in v.violations), v.violations
    # No joint states after the stop at all (the bridge gone): no evidence, no violation.
    assert judge(record([0.5] * 100)).ok
    # Slow braking that settles within the run is fine.
    assert judge(record([0.5] * 100 + [0.3] * 30 + [0.0] * 50)).ok
    # A bridge frozen through the stop: no states, then one at rest just before shutdown.
    frozen = record([0.5] * 100)
    frozen.joints.append((1.9, js(0.0, 1.9)))
    assert judge(frozen).ok, judge(frozen).violations
    frozen.joints.append((1.95, js(0.2, 1.95)))  # ... but one moving late state is caught
    assert any("never came to rest" in x for x in judge(frozen).violations)


def test_a_release_stop_that_never_settles_before_the_retract_is_caught():
    rec = record([0.4] * 100 + [0.2] * 100)
    rec.injections, rec.exit_code = [], 0
    rec.stops = [(1.0, MotionStop(**at(1.0), reason="release"))]
    rec.goals = [(1.8, MotionGoal(**at(1.8), goal_id="r", kind="retract"))]
    assert any("did not come to rest after the release stop" in x for x in judge(rec).violations)
    rec.goals = [(1.3, MotionGoal(**at(1.3), goal_id="r", kind="retract"))]  # retract before the deadline
    assert judge(rec).ok, judge(rec).violations


def test_latencies_come_from_the_senders_stamps_not_a_late_observer():
    """The observer received everything 0.8 s late (starved of CPU): the stop latency is the
    stack's, by the stamps, and the stamps' clock (wall) is mapped onto the test's."""
    speeds = [0.5] * 100 + [0.2, 0.05, 0.0] + [0.0] * 50  # braking ends at sender time 1.02 s
    rec = record(speeds)
    rec.joints = [(t + 0.8, m) for t, m in rec.joints]
    rec.stops = [(t + 0.8, m) for t, m in rec.stops]
    v = judge(rec)
    assert v.ok, v.violations
    assert abs(v.stop_s["kill motion @ transfer"] - 0.12) < 1e-9
    # The same run with a wall clock 1000 s ahead of the monotonic one: same latencies.
    shift = 1000.0
    rec2 = record(speeds)
    rec2.injections[0].at_wall_s += shift
    for name in ("joints", "stops"):
        setattr(rec2, name, [(t, type(m)(**{**{f: getattr(m, f) for f in m.__struct_fields__},
                                            "stamp_ns": m.stamp_ns + int(shift * 1e9)}))
                             for t, m in getattr(rec2, name)])
    assert abs(judge(rec2).stop_s["kill motion @ transfer"] - 0.12) < 1e-6


def test_a_killed_supervisor_is_detected_when_the_launcher_acts_not_when_the_test_reads_its_line():
    """The launcher's FAILURE line reached this (starved) test 0.2 s after the launcher's
    protective stop was sent: the detection is the stop's stamp, the stack's own act. A stop
    from another source, or not naming the service, is no detection of it."""
    rec = record([0.0] * 150, stop_at=1.0, service="supervisor")
    rec.stops = [(1.2, MotionStop(**{**at(0.93), "source": "launcher"}, protective=True,
                                  reason="protective stop: supervisor was killed by SIGKILL"))]
    rec.lines = [(1.2, "[launcher] FAILURE: supervisor was killed by SIGKILL")]
    v = judge(rec)
    assert abs(v.detection_s["kill supervisor @ transfer"] - 0.03) < 1e-9
    for stop in (MotionStop(**{**at(0.93), "source": "gripper"}, protective=True, reason="protective stop: supervisor"),
                 MotionStop(**{**at(0.93), "source": "launcher"}, protective=True, reason="protective stop: gripper")):
        rec.stops = [(1.2, stop)]
        assert abs(judge(rec).detection_s["kill supervisor @ transfer"] - 0.3) < 1e-9  # the line, read late
    # The bridge's own stop on the supervisor's lost token counts, by its stamp, as the launcher's.
    rec.stops = [(1.2, MotionStop(**{**at(0.92), "source": "bridge"}, protective=True,
                                  reason="protective stop: supervisor lost: its token went during transfer"))]
    assert abs(judge(rec).detection_s["kill supervisor @ transfer"] - 0.02) < 1e-9
