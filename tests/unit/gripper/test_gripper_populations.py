"""The benchmark's populations: the narrow one reproduces the first benchmark, the wide one
deals its sub-populations exactly, gripper classes set the actuator and the controllers'
period, and the per-sub-population figures add up to the overall ones."""

from __future__ import annotations

import csv
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from robot_sim.contact.config import SimConfig
from robot_sim.contact.receiver import LiftOrder, lift_order
from services.gripper.errors import GripperError
from services.studies.gripper import benchmark as B
from services.studies.gripper.attribution import run_attributed
from services.studies.gripper.bench_report import (
    subpopulation_table,
    write_subpopulation_csv,
    write_subpopulation_plot,
)
from services.studies.gripper.episodes import GRIPPER_CLASSES, RECEIVER_KINDS, EpisodeDistribution, sample_chunk
from services.studies.gripper.populations import POPULATIONS, allocate, plan_chunks, population, subpopulations

WIDE = POPULATIONS["wide"]


def test_narrow_population_reproduces_the_first_benchmark():
    # Pinned from the benchmark before the population was widened (seed 3, 40 episodes, chunks of 15).
    r = B.run_benchmark(["SG"], 40, seed=3, workers=1, chunk_size=15, progress=False, dist="narrow")
    assert r.outcomes["SG"].dropped.astype(int).tolist() == [
        0, 0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0,
        1, 0, 0, 1, 1, 1, 1, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    assert float(np.nansum(r.outcomes["SG"].force_overshoot_n)) == pytest.approx(398.6746544927138, rel=1e-12)
    assert r.population == "narrow" and np.all(r.control_period_s == 0.01)
    assert [s.kind for s in subpopulations(r.dist)] == ["taking", "dropping", "hesitating", "bumping"]


def test_wide_population_deals_every_sub_population_exactly_and_repeatably():
    assert allocate(10, [1.0, 1.0, 1.0]).tolist() == [4, 3, 3]
    assert allocate(7, [0.5, 0.25, 0.25]).tolist() == [3, 2, 2]  # 3.5, 1.75, 1.75: the two .75 get the rest
    subs = subpopulations(WIDE)
    assert len(subs) == 6 * 4 and len(set(subs)) == 24
    for n, chunk in ((48, 10), (50, 7)):
        plans = plan_chunks(WIDE, n, chunk, seed=0)
        assert sum(p.size for p in plans) == n and max(p.size for p in plans) <= chunk
        counts = Counter((k, p.gripper) for p in plans for k in p.kinds)
        assert set(counts) == {(s.kind, s.gripper) for s in subs}
        assert min(counts.values()) == n // 24 and max(counts.values()) <= n // 24 + 1
        again = plan_chunks(WIDE, n, chunk, seed=0)
        assert [p.kinds for p in again] == [p.kinds for p in plans]
    assert [p.kinds for p in plan_chunks(WIDE, 48, 10, seed=1)] != [p.kinds for p in plan_chunks(WIDE, 48, 10, seed=0)]


def test_gripper_class_sets_the_actuator_sensor_and_controller_rates():
    rng = np.random.default_rng(0)
    fast = sample_chunk(WIDE, 6, rng, gripper="fast", kinds=["pull-first", "drag", "taking"] * 2)
    cfg = fast.config
    assert cfg.gripper.force_rate_n_per_s == pytest.approx(500.0) and cfg.gripper.loop_rate_hz == 250.0
    assert cfg.sensors.ft_rate_hz == 250.0 and fast.control_period_s == pytest.approx(0.004)
    orders = [LiftOrder.PULL_FIRST, LiftOrder.NEVER_LIFTS, LiftOrder.LIFT_FIRST]
    assert lift_order(fast.receivers).tolist() == orders * 2
    assert np.all(fast.behaviour == 0) and fast.kind.tolist() == [4, 5, 0] * 2
    slow = sample_chunk(WIDE, 3, rng, gripper="slow")
    base = SimConfig()
    assert slow.config.gripper == base.gripper and slow.config.sensors.ft_rate_hz == base.sensors.ft_rate_hz
    for name in ("SG", "FS1", "max-hold"):
        assert B.build_controller(name, fast.control_period_s).period_s == pytest.approx(0.004)

    class Counting:
        period_s = fast.control_period_s

        def reset(self, n):
            self.n, self.times = n, []

        def step(self, sample):
            self.times.append(sample.time_s)
            return np.full(self.n, 20.0)

    ctl = Counting()
    run_attributed(replace(cfg, duration_s=0.2), fast.receivers, ctl, seed=0)
    np.testing.assert_allclose(np.diff(ctl.times)[1:], 0.004)  # one command per loop tick
    with pytest.raises(GripperError, match="one gripper class"):
        sample_chunk(WIDE, 3, rng)
    with pytest.raises(GripperError):
        sample_chunk(WIDE, 3, rng, gripper="slow", kinds=["taking"])
    with pytest.raises(GripperError, match="unknown names"):
        EpisodeDistribution(gripper_weights={"warp": 1.0})
    with pytest.raises(GripperError, match="unknown population"):
        population("everything")
    assert list(population("wide", ["medium"]).gripper_weights) == ["medium"]
    assert set(GRIPPER_CLASSES) >= set(WIDE.gripper_weights) and set(WIDE.behaviour_weights) == set(RECEIVER_KINDS)


def test_sub_population_rows_one_per_controller_and_they_add_up(tmp_path):
    r = B.run_benchmark(["HI", "SG"], 48, seed=2, workers=1, chunk_size=12, progress=False)
    assert r.population == "wide"
    fast = r.gripper == list(GRIPPER_CLASSES).index("fast")
    assert np.all(r.control_period_s[fast] == 0.004) and np.all(r.control_period_s[r.gripper == 0] == 0.01)
    rows = B.subpopulation_stats(r)
    subs = subpopulations(r.dist)
    assert len(rows) == len(subs) * 2 + 2
    keys = [(x.receiver, x.gripper, x.stats.controller) for x in rows[:-2]]
    assert len(set(keys)) == len(keys) == 48
    assert {(s.receiver_label, s.gripper_label) for s in subs} == {(a, b) for a, b, _ in keys}
    overall = {x.stats.controller: x.stats for x in rows[-2:]}
    assert [x.receiver for x in rows[-2:]] == ["all", "all"]
    for name in ("HI", "SG"):
        part = [x.stats for x in rows[:-2] if x.stats.controller == name]
        assert all(p.episodes == 2 for p in part)
        tot = overall[name]
        for field in ("episodes", "drops", "taking_episodes", "handed_over", "held_to_end"):
            assert sum(getattr(p, field) for p in part) == getattr(tot, field), field
        assert tot.drops == int(r.outcomes[name].dropped.sum()) and tot.drop_rate == tot.drops / tot.episodes
        take, out = r.behaviour == 0, r.outcomes[name]
        assert tot.handed_over == int(out.handed_over[take].sum())
        assert tot.held_to_end == int((take & ~out.released & ~out.dropped).sum())
        assert tot == next(s for s in B.summarise(r) if s.controller == name)
    table = subpopulation_table(rows).splitlines()
    assert len(table) == 2 + len(rows) and table[-1].startswith("| all | all | SG | 48 |")
    with write_subpopulation_csv(rows, tmp_path / "sub.csv").open() as fh:
        got = list(csv.DictReader(fh))
    assert len(got) == len(rows) and list(got[0])[:4] == ["receiver", "gripper", "controller", "episodes"]
    assert sum(int(g["drops"]) for g in got[:-2] if g["controller"] == "SG") == overall["SG"].drops
    png = write_subpopulation_plot(rows, tmp_path)
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000
