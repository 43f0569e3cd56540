"""`handover-study tune` in process against `--engine` on one machine (docs/gripper.md, "Sweeps at
scale"): the wall time of one CMA-ES generation's evaluation (SG, `TUNE_BENCH_SETS` parameter
sets of its search box on the tuning set: seed 1000, 960 episodes of "wide", chunks of 240), in
this process and on a local Dask cluster of every core (started once, as `tune --engine` does;
its start-up is reported apart). The two are interleaved, `TUNE_BENCH_REPEATS` times each, and
the scores are checked equal.

Run:
    python -m pytest tests/bench/test_bench_tune_engine.py -m bench -s
Writes out/bench/tune_engine.json and prints a markdown table (median, p99, ratio to in process).
"""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from services.studies.engine import available_cores, open_cluster
from services.studies.gripper.oracle_family import bench_chunks
from services.studies.gripper.tuning import SPACES, engine_runner, evaluate
from tests.bench._report import save, summarize, table

SETS = int(os.environ.get("TUNE_BENCH_SETS", "12"))
REPEATS = int(os.environ.get("TUNE_BENCH_REPEATS", "5"))
HEADER = ("path", "generation median s", "p99 s", "ratio to in process", "episodes/s")


@pytest.mark.bench
@pytest.mark.timeout(3600)
def test_bench_tune_generation_in_process_vs_engine():
    chunks = bench_chunks(1000, 960, 240, "wide")
    space = SPACES["SG"]
    rng = np.random.default_rng(0)
    sets = [space.to_params(u) for u in rng.uniform(size=(SETS, len(space.names)))]
    workers = available_cores()
    t0 = time.perf_counter()
    with open_cluster(workers=workers) as client:
        start_s = time.perf_counter() - t0
        runner = engine_runner(client)
        here, there = [], []
        for _ in range(REPEATS):
            t = time.perf_counter()
            a = evaluate(chunks, "SG", sets)
            here.append(time.perf_counter() - t)
            t = time.perf_counter()
            b = evaluate(chunks, "SG", sets, runner)
            there.append(time.perf_counter() - t)
            np.testing.assert_array_equal(a.failed, b.failed)
            np.testing.assert_array_equal(a.overshoot_n, b.overshoot_n)
    base, eng = summarize(here), summarize(there)
    episodes = SETS * 960
    rows = [("in process", f"{base['median']:.2f}", f"{base['p99']:.2f}", "1.00", f"{episodes / base['median']:.0f}"),
            (f"engine, {workers} workers", f"{eng['median']:.2f}", f"{eng['p99']:.2f}",
             f"{eng['median'] / base['median']:.2f}", f"{episodes / eng['median']:.0f}")]
    print(table(rows, HEADER))
    print(f"local cluster start-up (once per tuning run): {start_s:.2f} s")
    results = {"sets": SETS, "episodes_per_set": 960, "workers": workers, "cluster_start_s": start_s,
               "in_process_s": base, "engine_s": eng}
    print(f"wrote {save('tune_engine', results)}")
