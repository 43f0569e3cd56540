"""The benchmark on each described arm's gripper (`--population arms`): the classes carry each
gripper's rates and force range into the plant, and the per-gripper rows add up."""

from __future__ import annotations

import numpy as np
import pytest

from handover_model import robots
from services.studies.gripper import benchmark as B
from services.studies.gripper.bench_report import gripper_table
from services.studies.gripper.episodes import GRIPPER_CLASSES, sample_chunk
from services.studies.gripper.populations import POPULATIONS, subpopulations

ARMS = POPULATIONS["arms"]


def test_every_arms_gripper_is_a_class_with_its_limits():
    assert [s.gripper for s in subpopulations(ARMS)][:4] == list(robots.BUILTIN)
    for name, desc in robots.BUILTIN.items():
        cfg = sample_chunk(ARMS, 2, np.random.default_rng(0), gripper=name, kinds=["taking"] * 2).config
        g = desc.gripper
        assert cfg.gripper.force_rate_n_per_s == pytest.approx(g.force_rate_n_s)
        assert cfg.gripper.loop_rate_hz == g.loop_rate_hz
        assert cfg.gripper.max_force_n == min(g.force_max_n, 140.0) and cfg.gripper.min_force_n == g.force_min_n
    # Baxter's gripper is the plant's default actuator, as the "slow" class is.
    assert GRIPPER_CLASSES["baxter"].setup(sample_chunk(ARMS, 1, np.random.default_rng(0), gripper="baxter",
                                                        kinds=["taking"]).config).gripper == \
        GRIPPER_CLASSES["slow"].setup(sample_chunk(ARMS, 1, np.random.default_rng(0), gripper="slow",
                                                   kinds=["taking"]).config).gripper
    assert GRIPPER_CLASSES["ur5"].label == "ur5 (75 N/s, 50 Hz, 20–140 N)"


def test_the_per_gripper_rows_add_up_and_name_each_grippers_best_controller():
    r = B.run_benchmark(["SG", "FS1"], 96, seed=2, workers=1, chunk_size=24, progress=False, dist="arms")
    rows = B.per_gripper_stats(r)
    assert list(dict.fromkeys(row.gripper.split(" ")[0] for row in rows)) == list(robots.BUILTIN)
    for name in ("SG", "FS1"):
        mine = [row.stats for row in rows if row.stats.controller == name]
        assert sum(s.episodes for s in mine) == 96 and len(mine) == 4
        assert sum(s.drops for s in mine) == int(r.outcomes[name].dropped.sum())
    tests = B.per_gripper_paired_tests(r)
    assert [t["gripper"].split(" ")[0] for t in tests] == list(robots.BUILTIN) and all(t["b"] == "FS1" for t in tests)
    so = np.asarray(r.gripper) == list(GRIPPER_CLASSES).index("so_arm101")
    sg, fs1 = r.outcomes["SG"].dropped[so], r.outcomes["FS1"].dropped[so]
    assert (tests[-1]["only_a_drops"], tests[-1]["only_b_drops"]) == (int((sg & ~fs1).sum()), int((~sg & fs1).sum()))
    table = gripper_table(rows)
    assert table.count("**SG**") + table.count("**FS1**") == 4 and "so_arm101 (150 N/s, 50 Hz, 0–10 N)" in table
    for gripper in robots.BUILTIN:  # the bold one has the fewest drops of its gripper
        mine = [row.stats for row in rows if row.gripper.startswith(gripper + " ")]
        best = min(s.drop_rate for s in mine)
        bold = [line for line in table.splitlines() if line.startswith(f"| {gripper} (") and "**" in line]
        assert len(bold) == 1 and f"{100 * best:.1f} [" in bold[0]
