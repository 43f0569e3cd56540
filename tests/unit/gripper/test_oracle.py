"""The clairvoyant bound (services/studies/gripper/oracle.py) on cases whose answer is known by
hand, its building blocks, and that no real controller beats it on the benchmark's episodes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from robot_sim.contact.config import ContactSimError, GRAVITY_M_S2, ObjectParams, SimConfig
from robot_sim.contact.controllers import ConstantGrip
from robot_sim.contact.episode import run_episode, run_vectorised
from robot_sim.contact.receiver import absent, stack_receivers, taking
from services.gripper.controllers.registry import make_controller
from services.studies.gripper.episodes import EpisodeDistribution, sample_chunk
from services.studies.gripper.oracle import (
    SEARCH,
    CommandTable,
    clairvoyant_bound,
    envelope_commands,
    latch_grid,
    random_tables,
    stuck_load,
    subset_episodes,
)


def test_latch_grid_is_the_actuators_position_loop():
    every, n_latch, period = latch_grid(SimConfig())
    assert (every, n_latch, period) == (40, 88, pytest.approx(0.04))  # 25 Hz over 3.5 s: latches at 0 … 3.48 s
    assert latch_grid(SimConfig(duration_s=1.0))[1] == 25


def test_envelope_is_the_tail_maximum_before_the_release_and_zero_after():
    need = np.array([[1.0, 3.0, 2.0, 1.0, 9.0], [1.0, 3.0, 2.0, 1.0, 9.0], [200.0, 1.0, 1.0, 1.0, 1.0]])
    c = envelope_commands(need, np.array([3, 5, 5]), margin=1.5, max_force_n=140.0)
    np.testing.assert_allclose(c[0], [4.5, 4.5, 3.0, 0.0, 0.0])  # max of need[j..2] × 1.5, then released
    np.testing.assert_allclose(c[1], [13.5, 13.5, 13.5, 13.5, 13.5])  # never released: the 9 N at the end rules
    np.testing.assert_allclose(c[2], [140.0, 1.5, 1.5, 1.5, 1.5])  # clipped to the actuator's largest force
    assert np.all(np.diff(c[:, :3], axis=1) <= 0)  # non-increasing before the release


def test_command_table_is_latched_at_25_hz_and_falls_at_the_actuators_rate():
    config = SimConfig(duration_s=0.5)
    table = np.zeros((1, latch_grid(config)[1]))
    table[0, :2] = 10.0  # 10 N at the latches of 0 and 40 ms, 0 N from the latch of 80 ms
    trace = run_episode(config, absent(), CommandTable(table, 0.04)).trace
    t, f = trace.time_s, trace.grip_force_n
    assert np.all(f[t < 0.0805] == pytest.approx(10.0))  # nothing changes before the third latch
    later = (t > 0.1) & (t < 0.2)
    rate = -np.diff(f[later]) / np.diff(t[later])
    assert rate.max() == pytest.approx(50.0, rel=1e-6)  # 0.1 m/s through 5 N/cm
    assert f[t >= 0.32].max() == 0.0  # 10 N / 50 N/s = 0.2 s after the latch, plus the 20 ms lag
    with pytest.raises(ContactSimError):
        CommandTable(-table, 0.04)


def test_subset_runs_the_same_episodes():
    chunk = sample_chunk(EpisodeDistribution(), 6, np.random.default_rng(3))
    full = run_vectorised(chunk.config, chunk.receivers, ConstantGrip(8.0), seed=0)
    cfg, rec = subset_episodes(chunk.config, chunk.receivers, [4, 1, 4])
    np.testing.assert_array_equal(cfg.obj.mass_kg, chunk.mass_kg[[4, 1, 4]])
    part = run_vectorised(cfg, rec, ConstantGrip(8.0), seed=0)  # the truth does not depend on the sensor noise
    for field in ("dropped", "handed_over", "force_overshoot_n", "slip_distance_m"):
        np.testing.assert_array_equal(getattr(part, field), getattr(full, field)[[4, 1, 4]])


def test_random_tables_are_admissible_piecewise_constant_sequences():
    t = random_tables(np.random.default_rng(0), 400, 30, 140.0)
    assert t.shape == (400, 30) and t.min() >= 0.0 and t.max() <= 140.0
    assert max(len(np.unique(row)) for row in t) <= 3
    assert 0.4 < np.mean(t[:, -1] == 0.0) < 0.6  # about half end released


def _heavy_slippery(config: SimConfig) -> SimConfig:
    return replace(config, obj=ObjectParams(mass_kg=20.0, mu_static=0.2, mu_kinetic=0.15))


def test_a_heavy_object_on_low_friction_is_unavoidably_dropped():
    config = _heavy_slippery(SimConfig(duration_s=1.0))
    assert 140.0 * 0.2 < 20.0 * GRAVITY_M_S2  # μ_s F_max < M g: no admissible grip can hold it
    need, hold = stuck_load(config, stack_receivers([absent(), taking(weight_n=196.2)]))
    assert np.all(need >= 20.0 * GRAVITY_M_S2 / 0.2 - 1e-9) and hold.dropped.all()
    bound = clairvoyant_bound(config, stack_receivers([absent(), taking(weight_n=196.2)]), search=16)
    assert bound.dropped.all() and not bound.success.any() and bound.max_hold_dropped.all()
    assert bound.searched.all()  # the falsification search ran and found nothing better either


def test_a_static_hold_is_kept_and_its_least_grip_is_w_over_mu():
    config = SimConfig(duration_s=1.0)
    need, hold = stuck_load(config, stack_receivers([absent()]))
    np.testing.assert_allclose(need, config.obj.weight_n / config.obj.mu_static, rtol=1e-12)  # 3.27 N everywhere
    bound = clairvoyant_bound(config, stack_receivers([absent()]), search=16)
    assert bound.success.all() and not bound.dropped.any() and not bound.searched.any()
    for grip in (1.05 * 3.27, 10.0, 140.0):  # any law at or above W/μ_s keeps it
        assert not run_vectorised(config, stack_receivers([absent()]), ConstantGrip(grip)).dropped.any()
    assert run_vectorised(config, stack_receivers([absent()]), ConstantGrip(0.9 * 3.27)).dropped.all()


def test_a_taking_receiver_is_handed_over_without_a_drop_and_gently():
    config = SimConfig()
    receivers = stack_receivers([taking()])
    bound = clairvoyant_bound(config, receivers, search=0)
    assert bound.success.all() and bound.handed_over.all() and not bound.dropped.any()
    assert 0 <= bound.release_latch[0] < latch_grid(config)[1]
    assert 1 <= bound.release_window[0] < latch_grid(config)[1]  # a window of release latches, not all of them
    for name in ("HI", "SG"):  # the clairvoyant hands over with less force than a real controller
        real = run_vectorised(config, receivers, make_controller(name, period_s=0.01), seed=0)
        assert real.handed_over[0] and bound.overshoot_n[0] < real.force_overshoot_n[0]
    with pytest.raises(ContactSimError):
        clairvoyant_bound(config, receivers, margin=0.9)


def test_no_controller_beats_the_clairvoyant_bound_on_benchmark_episodes():
    chunk = sample_chunk(EpisodeDistribution(), 36, np.random.default_rng(11))
    bound = clairvoyant_bound(chunk.config, chunk.receivers, search=8)
    taking_ = chunk.behaviour == 0
    assert taking_.any() and (~taking_).any()
    for name in ("FS1", "HI", "SG"):
        out = run_vectorised(chunk.config, chunk.receivers, make_controller(name, period_s=0.01), seed=5)
        ok = ~out.dropped & (out.handed_over | ~taking_)
        assert not np.any(ok & ~bound.success), name
        assert bound.success.sum() >= ok.sum()
    assert np.all(bound.source[~bound.searched] != SEARCH)
