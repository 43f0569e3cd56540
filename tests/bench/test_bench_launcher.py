"""handover-up: time from launch to every service alive (DESIGN §9: ≤ 5 s).

Baseline in the same run: the time to start one bare Python process that imports the
service runtime (what every service pays before it can connect).
Run: python -m pytest tests/bench/test_bench_launcher.py -m bench -s
"""

from __future__ import annotations

import re
import subprocess
import sys
import time

import pytest

from tests.bench._report import save, summarize, table

pytestmark = pytest.mark.bench
RUNS = 7


def test_time_to_all_alive(tmp_path):
    alive_s, baseline_s = [], []
    for i in range(RUNS):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import services.runtime"], check=True)
        baseline_s.append(time.perf_counter() - t0)
        res = subprocess.run([sys.executable, "-m", "services.launcher", "--port", "auto", "--job", "check",
                              "--recording-dir", str(tmp_path), "--run-id", f"b{i}"],
                             capture_output=True, text=True, timeout=60)
        assert res.returncode == 0, res.stdout + res.stderr
        match = re.search(r"alive [\d.]+ s after start \(([\d.]+) s after launch\)", res.stdout)
        assert match, res.stdout
        alive_s.append(float(match.group(1)))
    a, b = summarize(alive_s), summarize(baseline_s)
    print("\nhandover-up (sim profile: recorder + bridge) launch → all alive, s")
    print(table([("handover-up to all alive", f"{a['median']:.2f}", f"{a['p99']:.2f}", str(a["n"])),
                 ("baseline: python -c 'import services.runtime'", f"{b['median']:.2f}", f"{b['p99']:.2f}",
                  str(b["n"]))], ("what", "median", "p99", "runs")))
    print(f"ratio: {a['median'] / b['median']:.1f}x the bare interpreter start")
    save("time_to_alive", {"handover_up": a, "baseline_python_import": b,
                           "ratio_median": a["median"] / b["median"]})
    assert a["median"] < 15.0
