"""handover-up: time from launch to every service alive (DESIGN §9: ≤ 5 s).

Each run starts `handover-up --job check` on the default sim profile (every service) and
reads three numbers:
- wall: from spawning the `handover-up` process to its ``all N services alive`` line (what a
  user waits for, the launcher's own interpreter start included);
- after launch: the launcher's own count, from the start of its `run()` (router open, recorder
  first, then the others in parallel);
- per service: spawn → liveliness token, from the launcher's ``start-up, spawn → alive`` line.

Baseline in the same run: the time to start one bare Python process that imports the
service runtime (what every service pays before it can connect).
Run: python -m pytest tests/bench/test_bench_launcher.py -m bench -s
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time

import pytest

from tests.bench._report import save, summarize, table

pytestmark = pytest.mark.bench
RUNS = 7
TARGET_S = 5.0
_ALIVE = re.compile(r"all (?P<n>\d+) services alive [\d.]+ s after start \((?P<launch>[\d.]+) s after launch\)")
_PER_SERVICE = re.compile(r"start-up, spawn → alive: (?P<list>.*)$", re.M)


def _one_launch(tmp_path, run: int) -> tuple[float, float, int, dict[str, float], str]:
    """(wall s, after-launch s, services, per-service s, output) of one `--job check` run."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "services.launcher", "--port", "auto", "--job", "check",
                             "--recording-dir", str(tmp_path), "--run-id", f"b{run}"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    wall = float("nan")
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            if wall != wall and _ALIVE.search(line):  # first time only (nan != nan)
                wall = time.perf_counter() - t0
        proc.wait(60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    out = "".join(lines)
    assert proc.returncode == 0, out
    alive = _ALIVE.search(out)
    per = _PER_SERVICE.search(out)
    assert alive and per, out
    per_service = {name: float(s) for name, s in re.findall(r"(\w+) ([\d.]+) s", per["list"])}
    return wall, float(alive["launch"]), int(alive["n"]), per_service, out


def test_time_to_all_alive(tmp_path):
    load_before = os.getloadavg()
    wall_s, launch_s, baseline_s = [], [], []
    per_service: dict[str, list[float]] = {}
    services = 0
    for i in range(RUNS):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import services.runtime"], check=True)
        baseline_s.append(time.perf_counter() - t0)
        wall, launch, services, per, _out = _one_launch(tmp_path, i)
        wall_s.append(wall)
        launch_s.append(launch)
        for name, seconds in per.items():
            per_service.setdefault(name, []).append(seconds)
    load_after = os.getloadavg()
    w, a, b = summarize(wall_s), summarize(launch_s), summarize(baseline_s)
    print(f"\nhandover-up --job check, sim profile ({services} services), {RUNS} runs; "
          f"load average before {load_before[0]:.1f}, after {load_after[0]:.1f}")
    rows = [
        ("spawn handover-up → all alive (wall)", f"{w['median']:.2f}", f"{w['p99']:.2f}"),
        ("launcher run() → all alive", f"{a['median']:.2f}", f"{a['p99']:.2f}"),
        ("baseline: python -c 'import services.runtime'", f"{b['median']:.2f}", f"{b['p99']:.2f}"),
    ]
    per_summary = {name: summarize(v) for name, v in per_service.items()}
    for name, s in sorted(per_summary.items(), key=lambda item: -item[1]["median"]):
        rows.append((f"  {name}: spawn → liveliness token", f"{s['median']:.2f}", f"{s['p99']:.2f}"))
    print(table(rows, ("what, s", "median", "p99")))
    print(f"ratio: wall {w['median'] / b['median']:.1f}x the bare interpreter start; "
          f"target ≤ {TARGET_S:.0f} s {'met' if w['median'] <= TARGET_S else 'NOT met'} (median wall)")
    save("time_to_alive", {"services": services, "wall": w, "after_launch": a, "baseline_python_import": b,
                           "per_service": per_summary, "ratio_median": w["median"] / b["median"],
                           "target_s": TARGET_S, "load_average_before": load_before,
                           "load_average_after": load_after})
    assert services >= 7
    assert set(per_service) and all(len(v) == RUNS for v in per_service.values())
    assert w["median"] > a["median"]  # the wall clock includes the launcher's own start
