"""The full fault matrix: each service × each handover phase × each fault, N runs per cell.

Run (hours for the whole matrix; resumable, bounded):

    python -m tests.faults.matrix --runs 10                         # everything
    python -m tests.faults.matrix --runs 1 --services motion,gripper \\
        --phases reach,transfer --faults-subset kill,freeze --budget-s 900

Every run is one `handover-up` (taking receiver) with one fault injected at the phase entry
(`harness.run_with_faults`) and judged by `invariants.judge` (strict exit off: a heavy delay
or drop that silences a stream may end in a named protective stop). Results accumulate in
``docs/data/faults/matrix.json`` (a cell with enough runs is skipped on the next call, so an
interrupted campaign resumes) and the table is rewritten to ``docs/data/faults/matrix.md`` after
every run. Cells are filled round by round (every chosen cell gets its 1st run, then its 2nd,
...), so a campaign stopped by its budget leaves an even table rather than a few full cells.
Each run records the commit it ran on, its start (UTC), wall time (and how it split into
start-up, episode and shutdown) and the machine's 1-minute load at its end; the launcher output
of a run that broke an invariant, that ended in a stop its fault does not explain
(`unexplained_stop`) or that the harness could not finish is kept in
``docs/data/faults/matrix_logs/<service>-<phase>-<fault>-<seed>.log`` for diagnosis.

Per service, delay/drop/flood hit the topic it publishes that the handover depends on most
(`SERVICE_TOPIC`); delay 0.3 s (twice the 0.15 s stream time-out), drop p = 0.5, flood
1000 payloads/s of non-decoding garbage for 2 s; freeze is 1 s of SIGSTOP.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from tests.faults.harness import run_with_faults
from tests.faults.invariants import REPORT_ONLY, FaultPlan, judge

#: Where the campaign of record lives (tracked: its runs took hours; `--out` for a scratch one).
OUT = Path(__file__).resolve().parents[2] / "docs" / "data" / "faults"
SERVICES = ("bridge", "motion", "gripper", "supervisor", "planner", "tracker", "recorder")
PHASES = ("locate", "pick", "plan", "reach", "transfer", "released")
FAULTS = ("kill", "freeze", "delay", "drop", "flood")
SERVICE_TOPIC = {
    "bridge": "robot/joint_state",
    "motion": "robot/joint_command",
    "gripper": "gripper/command",
    "supervisor": "motion/goal",
    "planner": "planner/transfer",
    "tracker": "perception/human",
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


#: How the launcher's exit line blames a service for a stop: the supervisor's protective stop,
#: the launcher's own verdict on a silent supervisor, a safety service that died.
_BLAMED = (re.compile(r"protective stop: (\w+):"), re.compile(r"exit \d+: (\w+): silent"),
           re.compile(r"exit \d+: (\w+) was killed"))


def stop_blames(exit_line: str) -> str | None:
    """The service the launcher's exit line blames for a stop (None: it blames none)."""
    for pattern in _BLAMED:
        m = pattern.search(exit_line)
        if m:
            return m.group(1)
    return None


def unexplained_stop(service: str, fault: str, exit_line: str) -> str | None:
    """Why a run's stop is not explained by its injected fault (None: it is, or no stop).

    A stop blaming another service than the faulted one is unexplained (e.g. a frozen motion
    service and the supervisor names the gripper); so is any stop after a flood of garbage
    (it must be dropped at decode and silence nothing), and a stop for the bridge's joint
    states after half of them were dropped (100 Hz: 20 in a row would have to be lost).
    """
    blamed = stop_blames(exit_line)
    if blamed is None:
        return None
    if blamed != service:
        return f"the stop blames {blamed}, not the faulted {service}"
    if fault == "flood":
        return "a flood of garbage ended in a stop"
    if fault == "drop" and service == "bridge":
        return "half the joint states dropped ended in a stop"
    return None


def stopped_before_the_fault(rec, plans: list[FaultPlan]) -> str | None:
    """The launcher's exit line when a run (`RunRecord`) ended before any of `plans` was
    injected, in a stop that blames a service none of the plans touches for being silent (a
    process starved of CPU); None otherwise. With no plans: any stop blaming a silent service."""
    blamed = stop_blames(rec.exit_line)
    if rec.injections or (plans and not rec.phases_missed) or blamed is None or "silent" not in rec.exit_line:
        return None
    return None if blamed in {p.service for p in plans} else rec.exit_line


def run_again_if_stopped_before_the_fault(label: str, plans: list[FaultPlan], **run_kwargs):
    """`run_with_faults(plans, **run_kwargs)`, and once more (printed, with ``-again`` added to
    the ``log_path`` stem) if that stack stopped before any fault was injected, on a service
    that looked silent and was not faulted (see `stopped_before_the_fault`): such a run says
    nothing about the faults, and a live process starved of CPU on a loaded machine is not the
    behaviour under test. A second such stop is returned as it is, for the caller to fail.

    Returns:
        (the run record that counts, the first stack's exit line if it was run again or None).
    """
    rec = run_with_faults(plans, **run_kwargs)
    starved = stopped_before_the_fault(rec, plans)
    if starved is None:
        return rec, None
    print(f"{label}: stack stopped before the fault ({starved}); running it once more")
    log_path = run_kwargs.get("log_path")
    if log_path is not None:
        run_kwargs["log_path"] = log_path.with_name(f"{log_path.stem}-again{log_path.suffix}")
    return run_with_faults(plans, **run_kwargs), starved


def wall_split(lines: list[tuple[float, str]], launched_s: float | None = None) -> dict[str, float]:
    """Where a run's wall time went, from the launcher's output lines (monotonic receive time,
    line): ``startup_s`` (`launched_s`, else the first line → "all N services alive"),
    ``episode_s`` (→ the line before the first "stopped <service>") and ``shutdown_s`` (→ the
    exit line). Parts whose marks are missing (a run cut short) are left out."""
    if not lines:
        return {}
    first_s = lines[0][0] if launched_s is None else launched_s
    alive_s = next((t for t, line in lines if line.startswith("[launcher] all ") and " alive " in line), None)
    stop_at = next((i for i, (_t, line) in enumerate(lines) if line.startswith("[launcher] stopped ")), None)
    exit_s = next((t for t, line in reversed(lines) if line.startswith("[launcher] exit ")), None)
    split: dict[str, float] = {}
    if alive_s is not None:
        split["startup_s"] = round(alive_s - first_s, 2)
    if stop_at is not None and stop_at > 0:
        shutdown_from_s = lines[stop_at - 1][0]
        if alive_s is not None:
            split["episode_s"] = round(shutdown_from_s - alive_s, 2)
        if exit_s is not None:
            split["shutdown_s"] = round(exit_s - shutdown_from_s, 2)
    return split


def write_atomic(path: Path, text: str) -> None:
    """Replace `path` with `text` in one step (a crash mid-write leaves the old file whole)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def current_commit() -> str:
    """The short hash of the checkout the runs start (with ``+dirty`` for local changes to
    anything but the results under ``out/``)."""
    repo = OUT.parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=repo, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":!out"], cwd=repo,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def round_robin(cells: list[tuple[str, str, str]], done: dict[str, int], runs: int) -> list[tuple[str, str, str]]:
    """The order of the runs still to do: round r gives every cell with fewer than r runs one
    more, for r = 1..`runs` (cells keyed ``service/phase/fault`` in `done`)."""
    order: list[tuple[str, str, str]] = []
    have = {c: done.get("/".join(c), 0) for c in cells}
    for round_no in range(1, runs + 1):
        for c in cells:
            if have[c] < round_no:
                order.append(c)
                have[c] += 1
    return order


def progress(results: dict, cells: list[tuple[str, str, str]], runs: int) -> str:
    """One line: how far the campaign over `cells` at `runs` per cell is, and the time left
    at the mean wall time of the runs so far."""
    todo = round_robin(cells, {k: len(c["runs"]) for k, c in results.items()}, runs)
    wanted = len(cells) * runs
    walls = [r["wall_s"] for c in results.values() for r in c["runs"] if "wall_s" in r]
    full = sum(1 for c in cells if len(results.get("/".join(c), {"runs": []})["runs"]) >= runs)
    least = min((len(results.get("/".join(c), {"runs": []})["runs"]) for c in cells), default=0)
    line = (f"{wanted - len(todo)} of {wanted} runs done ({100.0 * (wanted - len(todo)) / max(wanted, 1):.0f} %); "
            f"{full} of {len(cells)} cells have {runs} runs, every cell at least {least}")
    if todo and walls:
        mean_s = float(np.mean(walls))
        line += f"; {len(todo)} to go, about {len(todo) * mean_s / 3600.0:.1f} h at {mean_s:.1f} s a run"
    return line


def _latencies(runs: list[dict]) -> tuple[list[float], list[float]]:
    """Detection and stop latencies (s) of the runs measured by the senders' stamps (runs
    recorded before the judge used stamps say ``"latency_by": "receive"`` and are left out:
    their receive times include the observer's own delays)."""
    stamped = [r for r in runs if r.get("latency_by") == "stamps"]
    return ([r["detection_s"] for r in stamped if r["detection_s"] is not None],
            [r["stop_s"] for r in stamped if r["stop_s"] is not None])


def _pct(values: list[float], q: float) -> str:
    return f"{np.percentile(values, q) * 1000:.0f}" if values else "–"


def summary(results: dict) -> str:
    """Markdown: a service × fault grid (runs / runs with a violation, over all phases) and,
    per fault, the outcomes and the detection and stop latencies over all its runs."""
    grid: dict[tuple[str, str], list[int]] = {}
    by_fault: dict[str, list[dict]] = {}
    for cell in results.values():
        service, _phase, fault = cell["cell"]
        n_bad = grid.setdefault((service, fault), [0, 0])
        n_bad[0] += len(cell["runs"])
        n_bad[1] += sum(1 for r in cell["runs"] if r["violations"])
        # Report-only services (the recorder) are judged silent later by design: their
        # latencies get rows of their own, apart from the safety targets'.
        row = fault if service not in REPORT_ONLY else f"{fault}, {service} (report-only)"
        by_fault.setdefault(row, []).extend(cell["runs"])
    services = [s for s in SERVICES if any(k[0] == s for k in grid)]
    faults = [f for f in FAULTS if any(row.split(",")[0] == f for row in by_fault)]
    lines = ["| runs / violations | " + " | ".join(faults) + " |", "|---" * (len(faults) + 1) + "|"]
    for service in services:
        lines.append(f"| {service} | " + " | ".join(
            "{} / {}".format(*grid[(service, f)]) if (service, f) in grid else "–" for f in faults) + " |")
    lines += ["", "| fault | runs | outcomes | detection p50/p99 (ms), n | stop p50/p99 (ms), n |",
              "|---|---|---|---|---|"]
    for fault in sorted(by_fault, key=lambda r: (FAULTS.index(r.split(",")[0]), r)):
        runs = by_fault[fault]
        outcomes: dict[str, int] = {}
        for r in runs:
            name = "missed" if r["missed"] else r["outcome"]
            outcomes[name] = outcomes.get(name, 0) + 1
        det, stop = _latencies(runs)
        lines.append(f"| {fault} | {len(runs)} | " + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items()))
                     + f" | {_pct(det, 50)} / {_pct(det, 99)}, {len(det)} | {_pct(stop, 50)} / {_pct(stop, 99)}, "
                     f"{len(stop)} |")
    return "\n".join(lines) + "\n"


def render(results: dict) -> str:
    """Markdown: the headline, the `summary` and the table of the results (one row per cell)."""
    rows = ["| service | phase | fault | runs | violations | outcomes | detection p50/p99 (ms) | stop p50/p99 (ms) |",
            "|---|---|---|---|---|---|---|---|"]
    for key in sorted(results, key=lambda k: tuple(results[k]["cell"])):
        cell = results[key]
        runs = cell["runs"]
        det, stop = _latencies(runs)
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
    commits = sorted({r.get("commit", "unknown") for c in results.values() for r in c["runs"]})
    head = (f"Fault matrix: {len(results)} cells, {total} runs, {violations} runs with an invariant violation "
            f"(taking receiver; fault at the phase entry; latencies from the fault, by the senders' stamps; "
            f"commit{'s' if len(commits) > 1 else ''} {', '.join(commits)}).\n\n")
    return head + summary(results) + "\n" + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=10, help="runs per cell (default 10)")
    parser.add_argument("--services", default=",".join(SERVICES))
    parser.add_argument("--phases", default=",".join(PHASES))
    parser.add_argument("--faults-subset", default=",".join(FAULTS), help="comma-separated: " + ",".join(FAULTS))
    parser.add_argument("--budget-s", type=float, default=float("inf"), help="stop starting runs after this long")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--status", action="store_true", help="print the campaign's progress and exit (runs nothing)")
    args = parser.parse_args(argv)
    if args.runs < 0:
        print(f"matrix: --runs must be >= 0, got {args.runs}", file=sys.stderr)
        return 2
    chosen = [s.split(",") for s in (args.services, args.phases, args.faults_subset)]
    for got, allowed, what in zip(chosen, (SERVICES, PHASES, FAULTS), ("service", "phase", "fault"), strict=True):
        bad = [g for g in got if g not in allowed]
        if bad:
            print(f"matrix: unknown {what} {', '.join(bad)} (choose from {', '.join(allowed)})", file=sys.stderr)
            return 2
    args.out.mkdir(parents=True, exist_ok=True)
    json_path, md_path = args.out / "matrix.json", args.out / "matrix.md"
    try:
        results = json.loads(json_path.read_text()) if json_path.exists() else {}
    except (OSError, ValueError) as exc:
        print(f"matrix: cannot read {json_path} ({exc}); move it away to start a new campaign", file=sys.stderr)
        return 2
    cells = [(s, p, f) for s in chosen[0] for p in chosen[1] for f in chosen[2]]
    if args.status:
        print(f"matrix ({json_path}): {progress(results, cells, args.runs)}")
        return 0
    commit = current_commit()
    todo = round_robin(cells, {k: len(c["runs"]) for k, c in results.items()}, args.runs)
    print(f"matrix: {len(todo)} runs to do over {len(cells)} cells on commit {commit}", flush=True)
    try:
        with _interruptible():
            _campaign(args, results, todo, commit, json_path, md_path)
    except KeyboardInterrupt:
        print("matrix: interrupted; the run in progress is not recorded, the others are: run again to resume",
              file=sys.stderr)
        write_atomic(md_path, render(results))
        return 130
    write_atomic(md_path, render(results))
    print(f"matrix: {progress(results, cells, args.runs)}")
    return 0


class _interruptible:
    """SIGINT and SIGTERM raise KeyboardInterrupt inside the block (also when the campaign was
    started in the background, where SIGINT is ignored), so the harness's clean-up runs: the
    stack of the run in progress is shut down, no process is left behind."""

    def __enter__(self) -> None:
        def interrupt(signum: int, _frame: object) -> None:
            raise KeyboardInterrupt(signal.Signals(signum).name)

        self._previous = {s: signal.signal(s, interrupt) for s in (signal.SIGINT, signal.SIGTERM)}

    def __exit__(self, *exc: object) -> None:
        for s, handler in self._previous.items():
            signal.signal(s, handler)


def _campaign(args: argparse.Namespace, results: dict, todo: list[tuple[str, str, str]], commit: str,
              json_path: Path, md_path: Path) -> None:
    """Run `todo` in order, recording each run in `results` and the two files (see `main`)."""
    started = time.monotonic()
    for n_done, (service, phase, fault) in enumerate(todo):
        if time.monotonic() - started > args.budget_s:
            print(f"matrix: budget of {args.budget_s:.0f} s used up after {n_done} runs; run again to resume")
            break
        key = f"{service}/{phase}/{fault}"
        cell = results.setdefault(key, {"cell": [service, phase, fault], "runs": []})
        plan = plan_for(service, phase, fault)
        seed = len(cell["runs"])
        run_started = time.monotonic()
        started_utc = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        log_path = args.out / "matrix_logs" / f"{service}-{phase}-{fault}-{seed}.log"
        try:
            rec = run_with_faults([plan], receiver="taking", seed=seed, log_path=log_path)
        except Exception as exc:  # noqa: BLE001 - a harness failure is recorded, the campaign goes on
            run = {"seed": seed, "violations": [f"harness: {exc}"], "outcome": "error", "missed": False,
                   "detection_s": None, "stop_s": None, "exit_code": None, "exit_line": ""}
        else:
            v = judge(rec, strict_exit=False)
            run = {"seed": seed, "violations": v.violations, "outcome": v.outcome,
                   "missed": bool(rec.phases_missed), "exit_code": v.exit_code, "exit_line": v.exit_line,
                   "detection_s": v.detection_s.get(plan.label), "stop_s": v.stop_s.get(plan.label),
                   **wall_split(getattr(rec, "lines", []), run_started)}
        run["commit"] = current_commit()  # the checkout this run started (it may move on)
        run["latency_by"] = "stamps"
        run["wall_s"] = round(time.monotonic() - run_started, 2)
        run["started_utc"] = started_utc
        run["load_1m"] = round(os.getloadavg()[0], 2)  # the machine's load at the end of the run
        odd = unexplained_stop(service, fault, run["exit_line"] or "")
        if odd:
            run["unexplained_stop"] = odd
        if run["violations"] or odd:
            run["log"] = str(log_path.relative_to(args.out))
        else:
            log_path.unlink(missing_ok=True)  # only the runs worth a look keep their output
        cell["runs"].append(run)
        print(f"[{n_done + 1}/{len(todo)}] {key} run {len(cell['runs'])}: {run['outcome']} "
              f"exit {run['exit_code']} violations {len(run['violations'])} ({run['wall_s']:.0f} s)"
              + (f" UNEXPLAINED STOP: {odd}" if odd else ""), flush=True)
        write_atomic(json_path, json.dumps(results, indent=1))
        write_atomic(md_path, render(results))


if __name__ == "__main__":
    sys.exit(main())
