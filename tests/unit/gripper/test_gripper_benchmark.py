"""Monte-Carlo benchmark: statistics, episode sampling, per-episode object parameters,
common random numbers, and the CLI."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from robot_sim.contact.config import ObjectParams, SensorParams, SimConfig
from robot_sim.contact.controllers import ConstantGrip
from robot_sim.contact.episode import run_vectorised
from robot_sim.contact.receiver import stack_receivers, taking
from services.gripper.errors import GripperError
from services.studies.cli import main as study_main
from services.studies.gripper import benchmark as B
from services.studies.gripper.bench_report import markdown_table
from services.studies.gripper.episodes import EpisodeDistribution, EpisodeObjectParams, sample_chunk


def test_wilson_interval_matches_the_closed_form():
    k, n, z = 37, 500, 1.959963984540054
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    lo, hi = B.wilson_ci(k, n)
    assert lo == pytest.approx(centre - half, abs=1e-9) and hi == pytest.approx(centre + half, abs=1e-9)
    assert B.wilson_ci(0, 20)[0] == 0.0 and all(math.isnan(v) for v in B.wilson_ci(0, 0))


def test_sampled_episodes_respect_the_ranges_and_the_seed():
    dist = EpisodeDistribution()
    a = sample_chunk(dist, 400, np.random.default_rng(5))
    b = sample_chunk(dist, 400, np.random.default_rng(5))
    np.testing.assert_array_equal(a.mass_kg, b.mass_kg)
    assert a.mass_kg.min() >= 0.05 and a.mass_kg.max() <= 0.6
    assert a.mu_static.min() >= 0.2 and a.mu_static.max() <= 0.9
    assert np.all(np.abs(np.degrees(a.pull_angle_rad)) <= 45.0)
    assert np.all(a.config.obj.mu_kinetic <= a.config.obj.mu_static)
    frac_taking = np.mean(a.behaviour == 0)
    assert 0.33 < frac_taking < 0.47  # 40 % ± 3.5 σ
    assert set(np.unique(a.behaviour)) == {0, 1, 2, 3}
    with pytest.raises(GripperError):
        EpisodeDistribution(mass_kg=(0.6, 0.05))
    with pytest.raises(GripperError):
        EpisodeDistribution(behaviour_weights={"juggling": 1.0})


def test_per_episode_masses_match_scalar_runs_bit_for_bit():
    quiet = SensorParams(ft_noise_std_n=0.0, ft_bias_std_n=0.0)
    base = SimConfig(sensors=quiet, duration_s=2.0)
    masses, mus = [0.1, 0.45], [0.3, 0.8]
    recs = [taking(weight_n=m * 9.81, transfer_s=0.4) for m in masses]
    obj = EpisodeObjectParams(mass_kg=np.array(masses), mu_static=np.array(mus), mu_kinetic=0.8 * np.array(mus))
    mixed = run_vectorised(replace(base, obj=obj), stack_receivers(recs), ConstantGrip(6.0), seed=0)
    for i, (m, mu) in enumerate(zip(masses, mus)):
        cfg = replace(base, obj=ObjectParams(mass_kg=m, mu_static=mu, mu_kinetic=0.8 * mu))
        one = run_vectorised(cfg, stack_receivers([recs[i]]), ConstantGrip(6.0), seed=0)
        for field in ("dropped", "released", "force_overshoot_n", "slip_distance_m", "mode_switch_count"):
            assert getattr(mixed, field)[i] == getattr(one, field)[0], field
    # the light object is handed over, the heavy low-friction one is not held by 6 N: different outcomes
    assert mixed.slip_distance_m[0] != mixed.slip_distance_m[1]


def test_same_episodes_for_every_controller_and_repeatable():
    r1 = B.run_benchmark(["FS1", "SG"], 12, seed=3, workers=1, chunk_size=6, progress=False)
    r2 = B.run_benchmark(["SG"], 12, seed=3, workers=1, chunk_size=6, progress=False)
    np.testing.assert_array_equal(r1.outcomes["SG"].dropped, r2.outcomes["SG"].dropped)
    np.testing.assert_array_equal(r1.outcomes["SG"].force_overshoot_n, r2.outcomes["SG"].force_overshoot_n)
    np.testing.assert_array_equal(r1.mass_kg, r2.mass_kg)
    rows = B.summarise(r1)
    assert [r.controller for r in rows] == ["FS1", "SG"]
    for r, out in zip(rows, r1.outcomes.values()):
        assert r.drops == int(out.dropped.sum()) and r.episodes == 12
        take = r1.behaviour == 0
        assert r.taking_episodes == int(take.sum())
    t = B.paired_drop_test(r1, "SG", "FS1")
    d_sg, d_fs = r1.outcomes["SG"].dropped, r1.outcomes["FS1"].dropped
    assert t["only_a_drops"] == int((d_sg & ~d_fs).sum()) and t["only_b_drops"] == int((~d_sg & d_fs).sum())
    assert "| SG |" in markdown_table(rows)


def test_cli_writes_table_and_csv_and_rejects_bad_input(tmp_path, capsys):
    assert study_main(["bench", "--controllers", "HI", "-n", "4", "--chunk-size", "4", "--workers", "1", "--no-plots",
                   "--no-progress", "--out", str(tmp_path)]) == 0
    lines = (tmp_path / "table.md").read_text().splitlines()
    assert sum(line.startswith("| HI |") for line in lines) == 1  # the headline row
    # and one row per sub-population of the default "wide" population (6 kinds × 4 grippers), plus "all"
    assert sum(line.split(" | ")[2:3] == ["HI"] for line in lines) == 6 * 4 + 1
    assert (tmp_path / "results.csv").read_text().startswith("controller,episodes,drops")
    assert study_main(["bench", "--controllers", "FS9", "-n", "4", "--no-progress", "--out", str(tmp_path)]) == 2
    assert "unknown controller" in capsys.readouterr().err


def test_cli_set_overrides_one_controller_and_refuses_bad_ones(tmp_path, capsys):
    common = ["-n", "4", "--chunk-size", "4", "--workers", "1", "--no-plots", "--no-progress", "--seed", "5",
              "--population", "narrow"]
    assert study_main(["bench", "--controllers", "SG", *common, "--out", str(tmp_path / "v3")]) == 0
    assert study_main(["bench", "--controllers", "SG", *common, "--out", str(tmp_path / "as_v2"),
                       "--set", "SG:hold_per_weight=4", "--set", "SG:share_cap=3",
                       "--set", "SG:max_hold_force_n=inf"]) == 0
    assert study_main(["bench", "--controllers", "SG-v2", *common, "--out", str(tmp_path / "v2")]) == 0
    row = lambda d: (tmp_path / d / "results.csv").read_text().splitlines()[1].split(",", 1)[1]  # noqa: E731
    assert row("as_v2") == row("v2")  # SG with v2's three parameters is SG-v2, episode for episode
    assert row("v3") != row("v2")  # and the overrides did change something (seed 5: v2 holds the dropping receiver)
    capsys.readouterr()
    assert study_main(["bench", "--controllers", "SG", *common, "--out", str(tmp_path), "--set", "SG:colour=1"]) == 2
    assert "unknown parameter" in capsys.readouterr().err
    assert study_main(["bench", "--controllers", "SG", *common, "--out", str(tmp_path), "--set", "HI:eps=1"]) == 2
    assert "not in --controllers" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        study_main(["bench", "--controllers", "SG", *common, "--set", "SG:share_cap"])


def test_cli_against_makes_the_paired_tests_compare_with_that_controller(tmp_path, capsys):
    common = ["-n", "48", "--chunk-size", "48", "--workers", "1", "--no-plots", "--no-progress", "--seed", "5",
              "--population", "narrow", "--no-oracle"]
    assert study_main(["bench", "--controllers", "FS1", "HI", "SG", *common, "--attribute", "--against", "HI",
                       "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "paired drops HI vs FS1" in out and "paired drops HI vs SG" in out and "paired drops SG vs" not in out
    assert "HI − SG on all taking: median" in out and "paired bootstrap 95 % CI" in out
    rows = (tmp_path / "paired_overshoot.csv").read_text().splitlines()
    assert rows[0].startswith("against,other,episodes") and {r.split(",")[1] for r in rows[1:]} == {"FS1", "SG"}
    assert all(r.split(",")[0] == "HI" for r in rows[1:])
    assert study_main(["bench", "--controllers", "FS1", "HI", *common, "--against", "SG", "--out", str(tmp_path)]) == 2
    assert "--against SG is not in --controllers" in capsys.readouterr().err
    # Without SG and without --against, no paired tests and no error (as before the option).
    assert study_main(["bench", "--controllers", "FS1", "HI", *common, "--out", str(tmp_path / "b")]) == 0
    assert "paired drops" not in capsys.readouterr().out
