"""The fault matrix's run order and table, without running the stack."""

from __future__ import annotations

import json
import time

from tests.faults.matrix import (
    main,
    plan_for,
    progress,
    render,
    round_robin,
    stop_blames,
    stopped_before_the_fault,
    summary,
    unexplained_stop,
    wall_split,
)

CELLS = [("motion", "reach", "kill"), ("motion", "reach", "flood"), ("bridge", "transfer", "freeze")]

SUPERVISOR_STOP = ("[launcher] exit 1: episode 1: protective_stop: protective stop: gripper: silent: "
                   "no gripper/state for 0.206 s")
LAUNCHER_STOP = "[launcher] exit 1: supervisor: silent: no supervisor/state for 0.254 s; the launcher stopped the arm"
KILLED = "[launcher] exit 1: motion was killed by SIGKILL; it is a safety service, not restarted mid-episode"


def test_round_robin_fills_every_cell_before_any_second_run():
    order = round_robin(CELLS, {"motion/reach/flood": 1}, runs=3)
    # round 1: the two cells without a run; round 2: all three; round 3: all three
    assert order[:2] == [CELLS[0], CELLS[2]]
    assert order[2:5] == CELLS and order[5:] == CELLS
    assert len(order) == 3 * 3 - 1


def test_round_robin_has_nothing_to_do_for_full_cells():
    assert round_robin(CELLS, {"/".join(c): 10 for c in CELLS}, runs=10) == []
    assert round_robin(CELLS, {"/".join(c): 12 for c in CELLS}, runs=10) == []


def test_plan_for_targets_the_service_topic():
    flood = plan_for("tracker", "transfer", "flood")
    assert (flood.kind, flood.topic, flood.duration_s, flood.rate_hz) == ("flood", "perception/human", 2.0, 1000.0)
    assert plan_for("bridge", "reach", "kill").topic is None
    assert plan_for("gripper", "pick", "drop").value == 0.5


def _run(seed, violations=(), outcome="released", det=0.05, commit="abc1234"):
    return {"seed": seed, "violations": list(violations), "outcome": outcome, "missed": False, "exit_code": 0,
            "exit_line": "", "detection_s": det, "stop_s": None, "commit": commit, "latency_by": "stamps"}


def test_render_counts_runs_violations_and_commits():
    results = {"motion/reach/kill": {"cell": ["motion", "reach", "kill"],
                                     "runs": [_run(0, det=0.02), _run(1, ["arm moved"], "protective_stop", 0.04)]},
               "bridge/transfer/freeze": {"cell": ["bridge", "transfer", "freeze"],
                                          "runs": [_run(0, det=0.2, commit="def5678")]}}
    text = render(results)
    assert text.startswith("Fault matrix: 2 cells, 3 runs, 1 runs with an invariant violation")
    assert "commits abc1234, def5678" in text
    lines = text.splitlines()
    bridge = next(line for line in lines if line.startswith("| bridge | transfer |"))
    motion = next(line for line in lines if line.startswith("| motion | reach |"))
    assert lines.index(bridge) < lines.index(motion)  # sorted by cell
    assert "| 2 | 1 | protective_stop 1, released 1 | 30 / 40 |" in motion
    assert "| 1 | 0 | released 1 | 200 / 200 |" in bridge


def test_summary_grid_and_latencies_per_fault():
    results = {"motion/reach/kill": {"cell": ["motion", "reach", "kill"],
                                     "runs": [_run(0, det=0.02), _run(1, ["arm moved"], "protective_stop", 0.04)]},
               "motion/transfer/kill": {"cell": ["motion", "transfer", "kill"], "runs": [_run(0, det=0.03)]},
               "bridge/transfer/flood": {"cell": ["bridge", "transfer", "flood"], "runs": [_run(0, det=None)]}}
    lines = summary(results).splitlines()
    assert lines[0] == "| runs / violations | kill | flood |"
    assert lines[2] == "| bridge | – | 1 / 0 |" and lines[3] == "| motion | 3 / 1 | – |"
    kill = next(line for line in lines if line.startswith("| kill |"))
    assert kill == "| kill | 3 | protective_stop 1, released 2 | 30 / 40, 3 | – / –, 0 |"
    assert next(line for line in lines if line.startswith("| flood |")).endswith("| – / –, 0 | – / –, 0 |")


def test_progress_and_status(tmp_path, capsys):
    results = {"motion/reach/kill": {"cell": ["motion", "reach", "kill"], "runs": [_run(0), _run(1)]},
               "motion/reach/flood": {"cell": ["motion", "reach", "flood"], "runs": [_run(0)]}}
    for r in results["motion/reach/kill"]["runs"]:
        r["wall_s"] = 10.0
    results["motion/reach/flood"]["runs"][0]["wall_s"] = 16.0
    line = progress(results, CELLS, runs=2)
    # 6 runs wanted, 3 done; 1 of 3 cells full; bridge/transfer/freeze has none; 3 × 12 s left
    assert line == ("3 of 6 runs done (50 %); 1 of 3 cells have 2 runs, every cell at least 0; "
                    "3 to go, about 0.0 h at 12.0 s a run")
    (tmp_path / "matrix.json").write_text(json.dumps(results))
    assert main(["--status", "--runs", "2", "--services", "motion", "--phases", "reach",
                 "--faults-subset", "kill,flood", "--out", str(tmp_path)]) == 0
    assert "3 of 4 runs done (75 %); 1 of 2 cells have 2 runs, every cell at least 1" in capsys.readouterr().out
    assert main(["--status", "--services", "nobody", "--out", str(tmp_path)]) == 2
    assert "unknown service nobody" in capsys.readouterr().err
    (tmp_path / "matrix.json").write_text("{not json")
    assert main(["--status", "--out", str(tmp_path)]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_campaign_keeps_the_logs_of_runs_with_violations_or_unexplained_stops_only(tmp_path, monkeypatch, capsys):
    """The bookkeeping of `main` (the stack runs are stood in for: this is about the files)."""
    from types import SimpleNamespace

    from tests.faults import matrix

    def fake_run(plans, receiver, seed, log_path):
        log_path.parent.mkdir(parents=True, exist_ok=True)
        log_path.write_text(f"[launcher] run of {plans[0].label}\n")
        return SimpleNamespace(phases_missed=[], plan=plans[0])

    def fake_judge(rec, strict_exit):
        bad = rec.plan.kind == "flood"
        odd = rec.plan.kind == "delay"  # the stop blames the gripper, the fault hit motion
        return SimpleNamespace(violations=["arm moved"] if bad else [],
                               outcome="protective_stop" if odd else "released", exit_code=1 if odd else 0,
                               exit_line=SUPERVISOR_STOP if odd else "[launcher] exit 0",
                               detection_s={}, stop_s={})

    monkeypatch.setattr(matrix, "run_with_faults", fake_run)
    monkeypatch.setattr(matrix, "judge", fake_judge)
    args = ["--runs", "1", "--services", "motion", "--phases", "reach", "--faults-subset", "kill,delay,flood",
            "--out", str(tmp_path)]
    assert main(args) == 0
    results = json.loads((tmp_path / "matrix.json").read_text())
    flood, kill = results["motion/reach/flood"]["runs"][0], results["motion/reach/kill"]["runs"][0]
    delay = results["motion/reach/delay"]["runs"][0]
    assert flood["log"] == "matrix_logs/motion-reach-flood-0.log" and "log" not in kill
    assert delay["log"] == "matrix_logs/motion-reach-delay-0.log"
    assert delay["unexplained_stop"] == "the stop blames gripper, not the faulted motion"
    assert "unexplained_stop" not in kill and "unexplained_stop" not in flood
    assert "UNEXPLAINED STOP: the stop blames gripper" in capsys.readouterr().out
    assert (tmp_path / flood["log"]).read_text().startswith("[launcher] run of flood")
    assert not (tmp_path / "matrix_logs" / "motion-reach-kill-0.log").exists()
    assert flood["commit"] and flood["wall_s"] >= 0.0 and flood["load_1m"] >= 0.0
    assert flood["started_utc"].endswith("+00:00")
    assert "1 runs with an invariant violation" in (tmp_path / "matrix.md").read_text()
    assert main(args) == 0  # resumed: nothing left to do
    assert "0 runs to do" in capsys.readouterr().out


def test_campaign_interrupted_keeps_the_runs_before(tmp_path, monkeypatch, capsys):
    import os
    import signal
    from types import SimpleNamespace

    from tests.faults import matrix

    calls = []

    def fake_run(plans, receiver, seed, log_path):
        calls.append(plans[0].label)
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGTERM)  # as `kill <pid>` on a background campaign
            time.sleep(1.0)
        return SimpleNamespace(phases_missed=[])

    monkeypatch.setattr(matrix, "run_with_faults", fake_run)
    monkeypatch.setattr(matrix, "judge", lambda rec, strict_exit: SimpleNamespace(
        violations=[], outcome="released", exit_code=0, exit_line="", detection_s={}, stop_s={}))
    before = signal.getsignal(signal.SIGTERM)
    assert main(["--runs", "1", "--services", "motion", "--phases", "reach", "--faults-subset", "kill,flood,drop",
                 "--out", str(tmp_path)]) == 130
    assert signal.getsignal(signal.SIGTERM) is before  # handlers restored
    assert "interrupted" in capsys.readouterr().err
    results = json.loads((tmp_path / "matrix.json").read_text())
    assert [k for k, c in results.items() if c["runs"]] == ["motion/reach/kill"]


def test_latencies_measured_by_receive_time_are_left_out():
    old = _run(0, det=0.9)
    old["latency_by"] = "receive"  # recorded before the judge used the senders' stamps
    results = {"motion/reach/kill": {"cell": ["motion", "reach", "kill"], "runs": [old, _run(1, det=0.03)]}}
    text = render(results)
    assert "| kill | 2 | released 2 | 30 / 30, 1 |" in text
    assert "| 2 | 0 | released 2 | 30 / 30 |" in text


def test_stop_blames_reads_each_kind_of_exit_line():
    assert stop_blames(SUPERVISOR_STOP) == "gripper"
    assert stop_blames(LAUNCHER_STOP) == "supervisor"
    assert stop_blames(KILLED) == "motion"
    assert stop_blames("[launcher] exit 0: 1 of 1 episodes released") is None
    assert stop_blames("[launcher] exit 1: episode 1: failed: pick (lift): the move took longer than 10 s") is None
    assert stop_blames("") is None


def test_a_stop_is_unexplained_when_it_blames_another_service_or_follows_a_harmless_fault():
    # a frozen motion service, and the supervisor blames the gripper
    assert unexplained_stop("motion", "freeze", SUPERVISOR_STOP) == "the stop blames gripper, not the faulted motion"
    assert unexplained_stop("gripper", "freeze", SUPERVISOR_STOP) is None
    # a delayed motion stream, and the launcher found the supervisor silent
    assert "blames supervisor" in unexplained_stop("motion", "delay", LAUNCHER_STOP)
    assert unexplained_stop("supervisor", "freeze", LAUNCHER_STOP) is None
    assert unexplained_stop("motion", "kill", KILLED) is None
    flooded = "[launcher] exit 1: episode 1: protective_stop: protective stop: tracker: silent: no perception/human"
    assert unexplained_stop("tracker", "flood", flooded) == "a flood of garbage ended in a stop"
    assert unexplained_stop("tracker", "delay", flooded) is None  # a 0.3 s late stream is a stale stream
    dropped = "[launcher] exit 1: episode 1: protective_stop: protective stop: bridge: silent: no robot/joint_state"
    assert unexplained_stop("bridge", "drop", dropped) == "half the joint states dropped ended in a stop"
    assert unexplained_stop("bridge", "delay", dropped) is None
    assert unexplained_stop("motion", "drop", "[launcher] exit 0: 1 of 1 episodes released") is None


def test_wall_split_reads_startup_episode_and_shutdown_from_the_launcher_output():
    lines = [(100.0, "[launcher] bus on tcp/127.0.0.1:4000"),
             (100.5, "[launcher] started bridge (pid 1)"),
             (104.25, "[launcher] all 8 services alive 4.20 s after start (4.25 s after launch)"),
             (111.0, "[launcher]   phases: locate 0.00 s, pick 2.64 s"),
             (111.25, "[launcher] stopped supervisor (pid 8) with SIGINT: exited with code 0"),
             (113.0, "[launcher] stopped recorder (pid 2) with SIGINT: exited with code 0"),
             (113.5, "[launcher] exit 0: 1 of 1 episodes released")]
    assert wall_split(lines) == {"startup_s": 4.25, "episode_s": 6.75, "shutdown_s": 2.5}
    assert wall_split(lines[:3]) == {"startup_s": 4.25}  # cut short before the shutdown
    assert wall_split(lines, launched_s=99.75)["startup_s"] == 4.5
    assert wall_split([]) == {}


def test_a_run_stopped_by_a_starved_service_before_its_fault_is_told_apart():
    from tests.faults.invariants import FaultPlan, RunRecord

    plans = [FaultPlan("freeze", "tracker", "transfer", offset_s=0.3, duration_s=1.0)]
    starved = ("[launcher] exit 1: episode 1: protective_stop: protective stop: gripper: silent: "
               "no heartbeat for 0.252 s")
    rec = RunRecord(receiver="absent", exit_line=starved, phases_missed=["freeze tracker @ transfer"])
    assert stopped_before_the_fault(rec, plans) == starved
    # The faulted service itself silent before its fault: not a starved bystander, no second run.
    own = starved.replace("gripper:", "tracker:")
    assert stopped_before_the_fault(RunRecord(receiver="absent", exit_line=own, phases_missed=["x"]), plans) is None
    # A stop that is no silence (a process gone), or a run whose fault was injected, or one that
    # reached its phase: judged as it is.
    gone = starved.replace("silent: no heartbeat for 0.252 s", "process gone (liveliness token lost)")
    assert stopped_before_the_fault(RunRecord(receiver="absent", exit_line=gone, phases_missed=["x"]), plans) is None
    injected = RunRecord(receiver="absent", exit_line=starved, phases_missed=["x"], injections=[object()])
    assert stopped_before_the_fault(injected, plans) is None
    assert stopped_before_the_fault(RunRecord(receiver="absent", exit_line=starved), plans) is None


def test_a_run_without_faults_stopped_by_a_silent_service_is_told_apart():
    from tests.faults.invariants import RunRecord

    starved = ("[launcher] exit 1: episode 1: protective_stop: protective stop: tracker: silent: "
               "no heartbeat for 0.252 s")
    assert stopped_before_the_fault(RunRecord(receiver="dropping", exit_line=starved), []) == starved
    gone = starved.replace("silent: no heartbeat for 0.252 s", "process gone (liveliness token lost)")
    assert stopped_before_the_fault(RunRecord(receiver="dropping", exit_line=gone), []) is None
    released = RunRecord(receiver="dropping", exit_line="[launcher] exit 0: 1 episode(s)")
    assert stopped_before_the_fault(released, []) is None


def test_a_stack_stopped_before_its_fault_is_run_once_more_and_only_once(tmp_path, monkeypatch, capsys):
    from tests.faults import matrix
    from tests.faults.invariants import RunRecord

    starved = ("[launcher] exit 1: episode 1: protective_stop: protective stop: tracker: silent: "
               "no heartbeat for 0.252 s")
    released = "[launcher] exit 0: 1 episode(s)"
    calls: list[dict] = []

    def fake_runs(exit_lines):
        lines = iter(exit_lines)

        def run_with_faults(plans, **kwargs):
            calls.append(kwargs)
            return RunRecord(receiver=kwargs["receiver"], exit_line=next(lines))
        return run_with_faults

    monkeypatch.setattr(matrix, "run_with_faults", fake_runs([released]))
    rec, first = matrix.run_again_if_stopped_before_the_fault("clean", [], receiver="taking",
                                                              log_path=tmp_path / "a.log")
    assert (rec.exit_line, first, len(calls)) == (released, None, 1)

    calls.clear()
    monkeypatch.setattr(matrix, "run_with_faults", fake_runs([starved, starved, released]))
    rec, first = matrix.run_again_if_stopped_before_the_fault("twice", [], receiver="taking",
                                                              log_path=tmp_path / "b.log")
    assert rec.exit_line == starved and first == starved  # the second stop is returned, not run a third time
    assert [c["log_path"].name for c in calls] == ["b.log", "b-again.log"]
    assert "twice: stack stopped before the fault" in capsys.readouterr().out
