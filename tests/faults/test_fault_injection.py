"""Fault injection on the whole stack (`handover-up` with every service a real process).

CI set (15 runs, ~20 s each):

- every critical service (bridge, motion, gripper, planner, tracker, supervisor) killed
  (SIGKILL) and frozen (SIGSTOP for 1 s, then SIGCONT) 0.3 s into the transfer phase, with
  the ``absent`` receiver (nobody takes the object, so the transfer phase lasts until its
  6 s time-out and the fault lands while the arm holds the object at the transfer point);
- with the ``taking`` receiver (the transfer phase lasts ~0.4 s: these faults are injected
  at the phase entry), the safety topics gripper/release, motion/stop, robot/joint_command
  and gripper/command delayed (one run), dropped (one run) and flooded with garbage (one
  run), armed from the reach on; the recorder (report-only) is frozen from the locate phase
  to the end of the first of these runs (a hung recorder must not hold the bus back) and
  killed at the transfer entry in the second.

A stack stopped by the watchdog before any fault was injected, blaming the silence of a
service no fault touches (a process starved of CPU on 2 cores; the full matrix's
"unexplained stops"), says nothing about the faults: it is run once more, reported on stdout
and in its JSON; a second such stop fails.

Each run is judged by `invariants.judge`: never dropped, no motion after a protective stop or
a release, the fault named in the summary or the exit line, exit 1 with the reason for a
critical service and 0 otherwise. Latencies go to ``<DEFAULT_DIR>/<run>.json`` (`tests/faults/report.py`).
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from tests.faults.invariants import FaultPlan, judge
from tests.faults.matrix import run_again_if_stopped_before_the_fault
from tests.faults.report import DEFAULT_DIR

pytestmark = [pytest.mark.integration, pytest.mark.timeout(180)]

OUT = DEFAULT_DIR  # one JSON per run, outside the checkout (tests/faults/report.py)
CRITICAL = ("bridge", "motion", "gripper", "planner", "tracker", "supervisor")
SAFETY_TOPICS = (  # (publisher, topic)
    ("gripper", "gripper/release"),
    ("supervisor", "motion/stop"),
    ("motion", "robot/joint_command"),
    ("gripper", "gripper/command"),
)
#: Delays and drop rates the stack must ride through without a protective stop.
TOLERATED_DELAY_S = {"gripper/release": 0.05, "motion/stop": 0.05, "robot/joint_command": 0.02,
                     "gripper/command": 0.02}
TOLERATED_DROP_P = 0.3


def _save(name: str, rec, verdict, stopped_before_the_fault: str | None = None) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    doc = {
        "run": name,
        "receiver": rec.receiver,
        "faults": [asdict(i.plan) | {"injected_after_phase_entry_s": i.at_s - i.phase_seen_s,
                                     "flood_messages": i.sent} for i in rec.injections],
        "missed": rec.phases_missed,
        "outcome": verdict.outcome,
        "exit_code": verdict.exit_code,
        "exit_line": verdict.exit_line,
        "violations": verdict.violations,
        "detection_s": verdict.detection_s,
        "stop_s": verdict.stop_s,
        "first_stack_stopped_before_the_fault": stopped_before_the_fault,
    }
    (OUT / f"{name}.json").write_text(json.dumps(doc, indent=2))


def _run(name: str, plans: list[FaultPlan], receiver: str, tmp_path: Path):
    # The faults under test were never injected if the first stack stopped before them: it is
    # run once more, reported on stdout and in the run's JSON; a second such stop fails.
    rec, starved = run_again_if_stopped_before_the_fault(
        name, plans, receiver=receiver, log_path=tmp_path / f"{name}.log")
    verdict = judge(rec)
    _save(name, rec, verdict, stopped_before_the_fault=starved)
    log_tail = "\n".join(line for _t, line in rec.lines if line.startswith("[launcher]"))[-3000:]
    assert not rec.phases_missed, f"faults not injected (phase never reached): {rec.phases_missed}\n{log_tail}"
    assert verdict.ok, "\n".join(verdict.violations) + "\n" + log_tail
    return rec, verdict


@pytest.mark.parametrize("kind", ["kill", "freeze"])
@pytest.mark.parametrize("service", CRITICAL)
def test_critical_service_fault_in_transfer_stops_the_arm_and_is_named(service, kind, tmp_path):
    plan = FaultPlan(kind, service, "transfer", offset_s=0.3, duration_s=1.0 if kind == "freeze" else 0.0)
    rec, verdict = _run(f"{kind}-{service}-transfer", [plan], "absent", tmp_path)
    summary = rec.summaries[-1][1] if rec.summaries else None
    assert rec.exit_code == 1 and service in rec.exit_line, rec.exit_line
    if service != "supervisor":
        # The supervisor made the protective stop and named the service.
        assert summary is not None and summary.outcome == "protective_stop", summary
        assert summary.reason.startswith(f"protective stop: {service}: "), summary.reason
        assert plan.label in verdict.detection_s
        if service != "bridge":
            # A killed bridge is the simulated robot gone; a frozen one is the robot frozen
            # with it (no joint state to time the stop from until SIGCONT, which may come
            # after the stack has already shut down).
            assert plan.label in verdict.stop_s, verdict
    # The object stayed in the gripper (the receiver is absent): sim truth to the end.
    assert rec.truth[-1][1].held_by == "gripper"


def test_delayed_safety_topics_and_a_frozen_recorder_still_hand_over(tmp_path):
    # The recorder hangs from the first phase to the end of the run (thawed only for the
    # shutdown): what it subscribes to backs up in its socket and the router's queues, the
    # safety topics (congestion control BLOCK) among them; the robot side must not wait for it.
    plans = [FaultPlan("freeze", "recorder", "locate", duration_s=120.0)]
    plans += [FaultPlan("delay", svc, "reach", topic=t, value=TOLERATED_DELAY_S[t]) for svc, t in SAFETY_TOPICS]
    rec, verdict = _run("delay-safety-topics", plans, "taking", tmp_path)
    _assert_released_to_the_receiver(rec)
    summary = rec.summaries[-1][1]
    assert any(f.startswith("recorder: silent") for f in summary.faults), summary.faults


def test_dropped_safety_messages_and_a_killed_recorder_still_hand_over(tmp_path):
    plans = [FaultPlan("drop", svc, "reach", topic=t, value=TOLERATED_DROP_P) for svc, t in SAFETY_TOPICS]
    plans.append(FaultPlan("kill", "recorder", "transfer"))
    rec, verdict = _run("drop-safety-topics", plans, "taking", tmp_path)
    _assert_released_to_the_receiver(rec)
    summary = rec.summaries[-1][1]
    assert any(f.startswith("recorder: process gone") for f in summary.faults), summary.faults


def test_garbage_flood_on_safety_topics_changes_nothing(tmp_path):
    plans = [FaultPlan("flood", svc, "reach", topic=t, duration_s=3.0, rate_hz=500.0) for svc, t in SAFETY_TOPICS]
    rec, verdict = _run("flood-safety-topics", plans, "taking", tmp_path)
    _assert_released_to_the_receiver(rec)
    assert all(i.sent >= 500 for i in rec.injections), [(i.plan.label, i.sent) for i in rec.injections]
    assert rec.summaries[-1][1].faults == []


def _assert_released_to_the_receiver(rec) -> None:
    summary = rec.summaries[-1][1]
    assert summary.outcome == "released", summary
    assert rec.exit_code == 0, rec.exit_line
    assert rec.truth[-1][1].held_by == "receiver"
    assert rec.releases, "no release event on the bus"
