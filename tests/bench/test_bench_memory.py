"""Memory of every service during a full simulated handover (DESIGN §9: each ≤ 300 MB RSS).

Runs `handover-up` (one taking episode) as a subprocess, reads the children's PIDs from its
`started <name> (pid N)` lines, samples each child's resident set size with psutil every
0.2 s until the run ends, and reports each service's peak. Baseline in the same run: the RSS
of a bare Python process that imported the service runtime (what every service pays before
its own work).
Run: python -m pytest tests/bench/test_bench_memory.py -m bench -s
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
import time

import psutil
import pytest

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
    proc = subprocess.Popen([sys.executable, "-m", "services.launcher", "--port", "auto", "--receiver", "taking",
                             "--recording-dir", str(tmp_path), "--run-id", "mem"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    pids: dict[str, int] = {}
    lines: list[str] = []

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            m = _STARTED.match(line)
            if m:
                pids[m["name"]] = int(m["pid"])

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    peak: dict[str, float] = {}
    try:
        deadline = time.monotonic() + 180.0
        while proc.poll() is None and time.monotonic() < deadline:
            for name, pid in list(pids.items()):
                try:
                    rss = psutil.Process(pid).memory_info().rss / 1e6
                except psutil.Error:
                    continue
                peak[name] = max(peak.get(name, 0.0), rss)
            time.sleep(0.2)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        reader.join(5.0)
    assert proc.returncode == 0, "".join(lines[-30:])
    rows = [(name, f"{mb:.0f}", "yes" if mb <= TARGET_MB else "NO") for name, mb in sorted(peak.items())]
    rows.append(("baseline: python + services.runtime", f"{baseline:.0f}", ""))
    print(f"\npeak RSS during one simulated handover, MB (target ≤ {TARGET_MB:.0f} MB each)")
    print(table(rows, ("service", "peak RSS MB", "≤ target")))
    save("memory", {"peak_rss_mb": peak, "baseline_mb": baseline, "target_mb": TARGET_MB})
    assert len(peak) == 7, f"sampled {sorted(peak)}"
