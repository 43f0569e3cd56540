"""The engine choice, measured (docs/engine.md): Dask distributed and Ray local clusters against
the home-made multiprocessing pool the studies used before, in one sitting, same workload.

For each candidate with 2 workers: start-up of the local cluster (until a first task has run
on every worker), its memory when idle (PSS of the whole process tree, minus this process's
before), the addresses it listens on, the per-task overhead (200 no-op tasks), and the
throughput of the chunked contact workload (`--episodes` mixed episodes of a constant 10 N
grip, chunks of 500, as `handover-contact batch` runs them), checked identical to a serial run;
plus each one's install footprint beyond the stack's other dependencies.

Run (Ray is compared only where it is installed; docs/engine.md says how, in a throwaway venv):
    python -m pytest tests/bench/test_bench_engine_choice.py -m bench -s
Writes out/bench/engine_choice.json and prints a markdown table.
"""

from __future__ import annotations

import functools
import gc
import os
import time

import numpy as np
import pytest

from robot_sim.contact.batch import plan_batch, run_chunk
from robot_sim.contact.config import SimConfig
from robot_sim.contact.controllers import ConstantGrip
from tests.bench import engine_candidates as C
from tests.bench._report import save, table

WORKERS = 2
EPISODES = int(os.environ.get("ENGINE_BENCH_EPISODES", "10000"))
REPEATS = 3
STACK_OTHERS = {"eclipse-zenoh", "msgspec", "numpy", "scipy", "placo", "ruckig", "opencv-python-headless",
                "rerun-sdk", "example-robot-data", "matplotlib", "tqdm", "psutil", "rosbags", "cryptography", "mujoco"}
ROOTS = {"Dask": {"dask", "distributed"}, "Ray": {"ray"}}


def _contact_tasks():
    cfg = SimConfig(duration_s=3.5)
    return plan_batch(cfg, "mixed", EPISODES, functools.partial(ConstantGrip, 10.0), seed=0, chunk_size=500)


def _measure(candidate, tasks, serial_drops: np.ndarray) -> dict:
    gc.collect()
    base_mb = C.tree_memory_mb()
    starts = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        candidate.start(WORKERS)
        starts.append(time.perf_counter() - t0)
        candidate.stop()
    candidate.start(WORKERS)
    try:
        time.sleep(2.0)  # idle
        idle_mb = C.tree_memory_mb() - base_mb
        ips = C.listening_ips()
        overhead = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            candidate.run(C.noop, list(range(200)))
            overhead.append((time.perf_counter() - t0) / 200)
        walls = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            results = candidate.run(run_chunk, tasks)
            walls.append(time.perf_counter() - t0)
        drops = np.concatenate([out.dropped for out, _rec in results])
    finally:
        candidate.stop()
    return {"start_s": float(np.median(starts)), "start_p99_s": float(np.percentile(starts, 99)),
            "idle_memory_mb": idle_mb, "listening": ips, "task_overhead_ms": 1e3 * float(np.median(overhead)),
            "wall_s": float(np.median(walls)), "episodes_per_s": EPISODES / float(np.median(walls)),
            "identical_to_serial": bool(np.array_equal(drops, serial_drops))}


@pytest.mark.bench
def test_bench_engine_choice():
    tasks = _contact_tasks()
    t0 = time.perf_counter()
    serial = [run_chunk(t) for t in tasks]
    serial_wall = time.perf_counter() - t0
    serial_drops = np.concatenate([out.dropped for out, _rec in serial])
    results: dict = {"episodes": EPISODES, "workers": WORKERS, "cpus": os.cpu_count(),
                     "serial": {"wall_s": serial_wall, "episodes_per_s": EPISODES / serial_wall}}
    rows = [("serial, this process (1 core)", "-", "-", "-", "-", f"{EPISODES / serial_wall:.0f}", "-", "-")]
    for cls in C.CANDIDATES:
        if not cls.available:
            results[cls.name] = {"skipped": "not installed"}
            continue
        r = _measure(cls(), tasks, serial_drops)
        label = next((k for k in ROOTS if cls.name.startswith(k)), None)
        if label:
            r["install_packages"], r["install_mb"] = C.install_footprint(ROOTS[label], STACK_OTHERS)
        results[cls.name] = r
        rows.append((cls.name, f"{r['start_s']:.2f}", f"{r['idle_memory_mb']:.0f}", f"{r['task_overhead_ms']:.2f}",
                     f"{r['wall_s']:.1f}", f"{r['episodes_per_s']:.0f}",
                     f"{r.get('install_packages', 0)} / {r.get('install_mb', 0):.0f} MB", " ".join(r["listening"])))
        assert r["identical_to_serial"], f"{cls.name} gave other results than the serial run"
    print()
    print(table(rows, ("engine", "start-up s", "idle memory MB (PSS)", "per-task overhead ms",
                       f"{EPISODES} episodes s", "episodes/s", "install: packages / size", "listens on")))
    print(f"wrote {save('engine_choice', results)}")
    # The chosen engine stays on loopback (Ray's figures are reported, its addresses included).
    dask = results[C.DaskCandidate.name]
    assert dask["listening"] == ["127.0.0.1"], f"Dask listens beyond loopback: {dask['listening']}"
