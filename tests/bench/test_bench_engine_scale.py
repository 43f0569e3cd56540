"""The contact benchmark at scale through the engine (docs/engine.md): `handover-study bench`'s
episodes (population "wide", one controller, SG) at 10 000, 100 000 and 1 000 000 episodes on a
local Dask cluster of every core; episodes/s and episodes/s per core, and the run's result
(drop rate) so that the sizes can be compared.

Run (the sizes can be chosen; 1 M takes about 20 min on 2 free cores):
    ENGINE_SCALE_EPISODES=10000,100000,1000000 python -m pytest tests/bench/test_bench_engine_scale.py -m bench -s
Writes out/bench/engine_scale.json and prints a markdown table.
"""

from __future__ import annotations

import os
import time

import pytest

from services.studies.gripper.benchmark import run_benchmark
from services.studies.engine import available_cores
from tests.bench._report import OUT_DIR, save, table

SIZES = [int(v) for v in os.environ.get("ENGINE_SCALE_EPISODES", "10000,100000").split(",")]
WORKERS = available_cores()
HEADER = ("episodes", "wall s", "episodes/s", "episodes/s per core", "SG drops %")


@pytest.mark.bench
@pytest.mark.timeout(6 * 3600)  # 1 M episodes: about half an hour on 2 cores
def test_bench_engine_scale():
    rows, results = [], {"workers": WORKERS, "controller": "SG", "population": "wide", "chunk_size": 250}
    for n in SIZES:
        t0 = time.perf_counter()
        res = run_benchmark(["SG"], n, seed=1, workers=WORKERS, chunk_size=250, progress=True)
        wall = time.perf_counter() - t0  # with the local cluster's start and the assembly of the results
        out = res.outcomes["SG"]
        assert len(out) == n
        rate = n / wall
        results[str(n)] = {"wall_s": wall, "engine_wall_s": res.wall_time_s, "episodes_per_s": rate,
                           "episodes_per_s_per_core": rate / WORKERS, "drop_rate": float(out.dropped.mean())}
        drops = 100 * out.dropped.mean()
        rows.append((f"{n:,}", f"{wall:.1f}", f"{rate:.0f}", f"{rate / WORKERS:.0f}", f"{drops:.2f}"))
        print(table(rows, HEADER), flush=True)
    print(f"wrote {save('engine_scale', results)}")
    markdown = OUT_DIR / "engine_scale.md"
    markdown.write_text(table(rows, HEADER) + "\n")
    print(f"wrote {markdown} (the table of docs/engine.md)")
