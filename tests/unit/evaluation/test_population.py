"""The evaluation's population: declared bounds hold, seeds reproduce, per-variable streams."""

from __future__ import annotations

import numpy as np
import pytest

from services.runtime.profile import load_profile_file
from services.studies.evaluation import population as pop
from services.studies.evaluation.episode_profile import episode_table, read_base_profile, write_episode_profile
from services.studies.evaluation.errors import EvaluationError

DRAWS = [pop.draw_episode(7, k) for k in range(400)]


def test_the_same_seed_draws_the_same_episodes_and_another_seed_other_ones():
    assert [pop.draw_episode(7, k) for k in range(20)] == DRAWS[:20]
    assert [pop.draw_episode(8, k).height_m for k in range(20)] != [d.height_m for d in DRAWS[:20]]
    assert len({d.sim_seed for d in DRAWS}) == len(DRAWS)


def test_every_drawn_value_lies_within_its_declared_range():
    heights = np.array([d.height_m for d in DRAWS])
    assert heights.min() >= pop.STATURE_RANGE_M[0] and heights.max() <= pop.STATURE_RANGE_M[1]
    bmi = np.array([d.weight_kg / d.height_m**2 for d in DRAWS])
    assert bmi.min() >= pop.BMI_RANGE_KG_M2[0] - 0.01 and bmi.max() <= pop.BMI_RANGE_KG_M2[1] + 0.01
    for d in DRAWS:
        assert 0.1 <= d.object_mass_kg <= 0.5 and 0.4 <= d.mu_static <= 1.0
        assert 0.7 * d.mu_static - 1e-4 <= d.mu_kinetic <= 0.9 * d.mu_static + 1e-4
        assert 0.6 <= d.hand_reach_duration_s <= 1.4 and -20 <= d.pull_angle_deg <= 20
        assert 0.01 <= d.ft_noise_std_n <= 0.10 and 0.0 <= d.ft_bias_std_n <= 0.20
        assert 0 <= d.sim_seed < 2**32
        declared = pop.BEHAVIOUR_PARAMETERS[d.behaviour]
        assert set(d.receiver) == set(declared)
        for name, value in d.receiver.items():
            assert declared[name][0] <= value <= declared[name][1]


def test_the_shares_follow_the_declared_weights():
    """400 draws: every share within 4.5 standard errors of its declared weight."""
    n = len(DRAWS)
    for behaviour, weight in pop.BEHAVIOUR_WEIGHTS.items():
        share = sum(d.behaviour == behaviour for d in DRAWS) / n
        assert abs(share - weight) < 4.5 * np.sqrt(weight * (1 - weight) / n), behaviour
    sitting = sum(d.posture == "sitting" for d in DRAWS) / n
    assert abs(sitting - pop.SITTING_SHARE) < 4.5 * np.sqrt(0.21 / n)
    heights = np.array([d.height_m for d in DRAWS])
    assert 1.65 < heights.mean() < 1.72  # the mixture's mean is 1.685 m


def test_changing_one_variable_does_not_move_the_others(monkeypatch):
    """Each variable has its own stream: a different stature distribution leaves the object alone."""
    before = pop.draw_episode(3, 5)
    monkeypatch.setitem(pop.STATURE_M, "men", (1.9, 0.01))
    monkeypatch.setitem(pop.STATURE_M, "women", (1.9, 0.01))
    after = pop.draw_episode(3, 5)
    assert after.height_m != before.height_m
    assert (after.object_mass_kg, after.mu_static, after.behaviour, after.sim_seed) == \
        (before.object_mass_kg, before.mu_static, before.behaviour, before.sim_seed)


def test_the_episode_profile_gives_every_service_the_same_receiver_and_object(tmp_path):
    draw = next(d for d in DRAWS if d.behaviour == "taking" and d.posture == "sitting")
    _path, base = read_base_profile("sim")
    profile = load_profile_file(write_episode_profile(base, draw, tmp_path / "p.toml"))
    contact = profile.service_config("bridge")["contact"]
    tracker = profile.service_config("tracker")
    assert (contact["height_m"], contact["posture"], contact["seed"]) == (draw.height_m, "sitting", draw.sim_seed)
    assert contact["receiver"] == draw.receiver and contact["object_mass_kg"] == draw.object_mass_kg
    assert (tracker["sim_kinect"]["height_m"], tracker["sim_kinect"]["posture"], tracker["sim_kinect"]["seed"]) == \
        (draw.height_m, "sitting", draw.sim_seed)
    assert tracker["weight_kg"] == draw.weight_kg and tracker["object_mass_kg"] == draw.object_mass_kg
    assert profile.service_config("planner")["object_mass_kg"] == draw.object_mass_kg
    assert profile.service_config("supervisor")["episodes"] == 1
    assert base["services"]["bridge"]["config"]["contact"]["height_m"] == 1.75  # the base is untouched
    assert episode_table(base, draw) == episode_table(base, draw)


def test_a_profile_without_the_simulated_scene_is_refused(tmp_path):
    with pytest.raises(EvaluationError, match="simulated handover scene") as exc:
        read_base_profile("baxter_fake")
    assert exc.value.bad_input
    with pytest.raises(EvaluationError, match="--profile") as exc:
        read_base_profile(str(tmp_path / "missing.toml"))
    assert exc.value.bad_input
