"""The full fault matrix: each service × each handover phase × each fault, N runs per cell.

Run (hours for the whole matrix; resumable, bounded):

    python -m tests.faults.matrix --runs 10                         # everything
    python -m tests.faults.matrix --runs 1 --services motion,gripper \\
        --phases reach,transfer --faults-subset kill,freeze --budget-s 900

Every run is one `handover-up` (taking receiver) with one fault injected at the phase entry
(`harness.run_with_faults`) and judged by `invariants.judge` (strict exit off: a heavy delay
or drop that silences a stream may end in a named protective stop). Results accumulate in
``out/faults/matrix.json`` (a cell with enough runs is skipped on the next call, so an
interrupted campaign resumes) and the table is rewritten to ``out/faults/matrix.md`` after
every run.

Per service, delay/drop/flood hit the topic it publishes that the handover depends on most
(`SERVICE_TOPIC`); delay 0.3 s (twice the 0.15 s stream time-out), drop p = 0.5, flood
1000 payloads/s of non-decoding garbage for 2 s; freeze is 1 s of SIGSTOP.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from tests.faults.harness import run_with_faults
from tests.faults.invariants import FaultPlan, judge

OUT = Path(__file__).resolve().parents[2] / "out" / "faults"
SERVICES = ("bridge", "motion", "gripper", "supervisor", "planner", "tracker", "kinect", "recorder")
PHASES = ("locate", "pick", "plan", "reach", "transfer", "released")
FAULTS = ("kill", "freeze", "delay", "drop", "flood")
SERVICE_TOPIC = {
    "bridge": "robot/joint_state",
    "motion": "robot/joint_command",
    "gripper": "gripper/command",
    "supervisor": "motion/goal",
    "planner": "planner/transfer",
    "tracker": "perception/human",
    "kinect": "perception/skeleton",
    "recorder": "runtime/heartbeat",
}
DELAY_S, DROP_P, FLOOD_S, FLOOD_HZ, FREEZE_S = 0.3, 0.5, 2.0, 1000.0, 1.0


def plan_for(service: str, phase: str, fault: str) -> FaultPlan:
    if fault == "kill":
        return FaultPlan("kill", service, phase)
    if fault == "freeze":
        return FaultPlan("freeze", service, phase, duration_s=FREEZE_S)
    topic = SERVICE_TOPIC[service]
    if fault == "delay":
        return FaultPlan("delay", service, phase, topic=topic, value=DELAY_S)
    if fault == "drop":
        return FaultPlan("drop", service, phase, topic=topic, value=DROP_P)
    return FaultPlan("flood", service, phase, topic=topic, duration_s=FLOOD_S, rate_hz=FLOOD_HZ)


def _pct(values: list[float], q: float) -> str:
    return f"{np.percentile(values, q) * 1000:.0f}" if values else "–"


def render(results: dict) -> str:
    """The Markdown table of the results (one row per cell)."""
    rows = ["| service | phase | fault | runs | violations | outcomes | detection p50/p99 (ms) | stop p50/p99 (ms) |",
            "|---|---|---|---|---|---|---|---|"]
    for key in sorted(results, key=lambda k: tuple(results[k]["cell"])):
        cell = results[key]
        runs = cell["runs"]
        det = [r["detection_s"] for r in runs if r["detection_s"] is not None]
        stop = [r["stop_s"] for r in runs if r["stop_s"] is not None]
        outcomes: dict[str, int] = {}
        for r in runs:
            name = "missed" if r["missed"] else r["outcome"]
            outcomes[name] = outcomes.get(name, 0) + 1
        bad = sum(1 for r in runs if r["violations"])
        service, phase, fault = cell["cell"]
        rows.append(f"| {service} | {phase} | {fault} | {len(runs)} | {bad} | "
                    + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()))
                    + f" | {_pct(det, 50)} / {_pct(det, 99)} | {_pct(stop, 50)} / {_pct(stop, 99)} |")
    total = sum(len(c["runs"]) for c in results.values())
    violations = sum(1 for c in results.values() for r in c["runs"] if r["violations"])
    head = (f"Fault matrix: {len(results)} cells, {total} runs, {violations} runs with an invariant violation "
            f"(taking receiver; fault at the phase entry; latencies from the fault).\n\n")
    return head + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=10, help="runs per cell (default 10)")
    parser.add_argument("--services", default=",".join(SERVICES))
    parser.add_argument("--phases", default=",".join(PHASES))
    parser.add_argument("--faults-subset", default=",".join(FAULTS), help="comma-separated: " + ",".join(FAULTS))
    parser.add_argument("--budget-s", type=float, default=float("inf"), help="stop starting runs after this long")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)
    chosen = [s.split(",") for s in (args.services, args.phases, args.faults_subset)]
    for got, allowed, what in zip(chosen, (SERVICES, PHASES, FAULTS), ("service", "phase", "fault"), strict=True):
        bad = [g for g in got if g not in allowed]
        if bad:
            print(f"matrix: unknown {what} {', '.join(bad)} (choose from {', '.join(allowed)})", file=sys.stderr)
            return 2
    args.out.mkdir(parents=True, exist_ok=True)
    json_path, md_path = args.out / "matrix.json", args.out / "matrix.md"
    results = json.loads(json_path.read_text()) if json_path.exists() else {}
    started = time.monotonic()
    for service in chosen[0]:
        for phase in chosen[1]:
            for fault in chosen[2]:
                key = f"{service}/{phase}/{fault}"
                cell = results.setdefault(key, {"cell": [service, phase, fault], "runs": []})
                while len(cell["runs"]) < args.runs:
                    if time.monotonic() - started > args.budget_s:
                        print(f"matrix: budget of {args.budget_s:.0f} s used up; run again to resume")
                        return 0
                    plan = plan_for(service, phase, fault)
                    seed = len(cell["runs"])
                    try:
                        rec = run_with_faults([plan], receiver="taking", seed=seed)
                    except Exception as exc:  # a harness failure is recorded, the campaign goes on
                        cell["runs"].append({"seed": seed, "violations": [f"harness: {exc}"], "outcome": "error",
                                             "missed": False, "detection_s": None, "stop_s": None,
                                             "exit_code": None, "exit_line": ""})
                    else:
                        v = judge(rec, strict_exit=False)
                        cell["runs"].append({
                            "seed": seed, "violations": v.violations, "outcome": v.outcome,
                            "missed": bool(rec.phases_missed), "exit_code": v.exit_code, "exit_line": v.exit_line,
                            "detection_s": v.detection_s.get(plan.label), "stop_s": v.stop_s.get(plan.label),
                        })
                    last = cell["runs"][-1]
                    print(f"{key} run {len(cell['runs'])}: {last['outcome']} exit {last['exit_code']} "
                          f"violations {len(last['violations'])}", flush=True)
                    json_path.write_text(json.dumps(results, indent=1))
                    md_path.write_text(render(results))
    md_path.write_text(render(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
