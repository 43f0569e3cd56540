"""Memory and CPU of every service during a full simulated handover (DESIGN §9: each ≤ 300 MB RSS).

Runs `handover-up` (one taking episode) as a subprocess, reads the children's PIDs from its
`started <name> (pid N)` lines, samples each child's resident set size with psutil every
0.2 s until the run ends, and reports each service's peak and its RSS at the end of the
episode (the last sample before the launcher's ``summary:`` line, i.e. after a whole pick,
reach, release and retract). Baseline in the same run: the RSS of a bare Python process that
imported the service runtime (what every service pays before its own work).

The same samples give each service's CPU time (user + system, s) over the whole run, start-up
included, up to its last sample (≤ 0.2 s before it exits): on two cores the stack's total
against the run's wall time says how much of the machine a handover takes.
Run: python -m pytest tests/bench/test_bench_memory.py -m bench -s
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time

import psutil
import pytest

from services.runtime.profile import load_profile_file
from tests.bench._report import save, table

pytestmark = pytest.mark.bench
TARGET_MB = 300.0
_STARTED = re.compile(r"^\[launcher\] started (?P<name>\w+) \(pid (?P<pid>\d+)\)")


def _baseline_mb() -> float:
    proc = subprocess.Popen([sys.executable, "-c", "import services.runtime, time; time.sleep(3)"])
    try:
        time.sleep(2.0)
        return psutil.Process(proc.pid).memory_info().rss / 1e6
    finally:
        proc.kill()
        proc.wait()


def test_peak_rss_of_every_service_during_a_handover(tmp_path):
    baseline = _baseline_mb()
    load_before = os.getloadavg()
    proc = subprocess.Popen([sys.executable, "-m", "services.launcher", "--port", "auto", "--receiver", "taking",
                             "--recording-dir", str(tmp_path), "--run-id", "mem"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    pids: dict[str, int] = {}
    lines: list[str] = []
    episode_over = threading.Event()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            m = _STARTED.match(line)
            if m:
                pids[m["name"]] = int(m["pid"])
            if line.startswith("[launcher] summary:") or line.startswith("[launcher] stopped "):
                episode_over.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    peak: dict[str, float] = {}
    end_of_episode: dict[str, float] = {}
    cpu_s: dict[str, float] = {}
    started_s = time.monotonic()
    try:
        deadline = time.monotonic() + 180.0
        while proc.poll() is None and time.monotonic() < deadline:
            for name, pid in list(pids.items()):
                try:
                    child = psutil.Process(pid)
                    rss = child.memory_info().rss / 1e6
                    times = child.cpu_times()
                except psutil.Error:
                    continue
                cpu_s[name] = times.user + times.system
                peak[name] = max(peak.get(name, 0.0), rss)
                if not episode_over.is_set():
                    end_of_episode[name] = rss
            time.sleep(0.2)
    finally:
        wall_s = time.monotonic() - started_s
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        reader.join(5.0)
    assert proc.returncode == 0, "".join(lines[-30:])
    expected = {s.name for s in load_profile_file("sim").services if s.enabled}
    rows = [(name, f"{end_of_episode.get(name, float('nan')):.0f}", f"{mb:.0f}",
             "yes" if mb <= TARGET_MB else "NO") for name, mb in sorted(peak.items())]
    rows.append(("baseline: python + services.runtime", f"{baseline:.0f}", "", ""))
    print(f"\nRSS of every service during one simulated handover, MB (target ≤ {TARGET_MB:.0f} MB each); "
          f"load average {load_before[0]:.1f} at the start")
    print(table(rows, ("service", "end of episode MB", "peak MB", "peak ≤ target")))
    total_cpu_s = sum(cpu_s.values())
    cpu_rows = [(name, f"{t:.2f}", f"{100.0 * t / total_cpu_s:.0f} %") for name, t in
                sorted(cpu_s.items(), key=lambda kv: -kv[1])]
    print(f"\nCPU time of every service over the run ({wall_s:.1f} s wall, start-up included): "
          f"{total_cpu_s:.1f} s in all = {total_cpu_s / wall_s:.2f} cores on average")
    print(table(cpu_rows, ("service", "CPU s", "share")))
    save("memory", {"peak_rss_mb": peak, "cpu_s": cpu_s, "wall_s": wall_s, "end_of_episode_rss_mb": end_of_episode,
                    "baseline_mb": baseline, "target_mb": TARGET_MB, "load_average_before": load_before,
                    "over_target": sorted(n for n, mb in peak.items() if mb > TARGET_MB)})
    assert set(peak) == expected, f"sampled {sorted(peak)}, profile has {sorted(expected)}"
    assert all(mb > baseline for mb in peak.values())  # every service holds at least the runtime
    assert set(cpu_s) == expected and all(t > 0.0 for t in cpu_s.values())
