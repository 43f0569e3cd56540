"""Outcome rules, seeded repeatability, and the vectorised path against the scalar one."""

from __future__ import annotations

import functools
from dataclasses import fields

import numpy as np
import pytest

from robot_sim.contact.batch import chunk_receivers, run_batch
from services.studies.engine import run_tasks
from robot_sim.contact.config import SensorParams
from robot_sim.contact.controllers import ConstantGrip, ReleaseAfter
from robot_sim.contact.episode import run_episode, run_vectorised
from handover_model.grip import Mode
from robot_sim.contact.outcome import EpisodeTrace, OutcomeAccumulator, outcome_from_trace
from robot_sim.contact.receiver import dropping, sample_behaviours, stack_receivers, taking

from tests.unit.contact.helpers import quiet_config

G, S, R = Mode.GRASP, Mode.SLIP, Mode.RELEASE


def _trace(mode, py, holds, pull_x, accel=None):
    n = len(mode)
    t = np.arange(n) * 0.1
    return EpisodeTrace(time_s=t, mode=np.array(mode, dtype=np.int8), grip_force_n=np.zeros(n),
                        pull_force_x_n=np.array(pull_x, float), pull_force_y_n=np.zeros(n),
                        object_position_x_m=np.zeros(n), object_position_y_m=np.array(py, float),
                        object_accel_y_m_s2=np.zeros(n) if accel is None else np.array(accel, float),
                        receiver_holds=np.array(holds, bool))


def test_outcome_rules_by_hand():
    tr = _trace(mode=[G, G, S, S, R, S, R, R], py=[0, 0, 0.01, 0.02, 0.03, 0.035, 0.05, 0.06],
                holds=[0, 0, 0, 1, 1, 1, 1, 1], pull_x=[0, 1, 3, 2, 5, 4, 7, 1], accel=[0, 0, 2, 1, 9, -3, 0, 0])
    out = outcome_from_trace(tr)
    assert out.released and out.release_time_s == pytest.approx(0.6)  # last RELEASE stretch starts at index 6
    assert not out.dropped and out.handed_over
    assert out.force_overshoot_n == 5.0  # max pull before index 6
    assert out.slip_distance_m == pytest.approx(0.01 + 0.01 + 0.005)  # steps ending in SLIP
    assert out.peak_down_accel_m_s2 == 9.0
    assert out.mode_switch_count == 4
    assert [m for _, m in out.mode_timeline] == [G, S, R, S, R]


def test_drop_rule_needs_distance_and_no_holder():
    tr = _trace(mode=[G, R, R, R], py=[0, 0.05, 0.11, 0.2], holds=[0, 0, 1, 0], pull_x=[0, 0, 0, 0])
    out = outcome_from_trace(tr)
    assert out.dropped and out.drop_time_s == pytest.approx(0.3) and not out.handed_over


def test_accumulator_matches_trace_rules():
    rng = np.random.default_rng(5)
    n, T = 50, 200
    mode = rng.integers(0, 3, size=(T, n)).astype(np.int8)
    mode[:, :10] = np.repeat(rng.integers(0, 3, size=(T // 20, 10)), 20, axis=0)  # long stretches too
    py = np.cumsum(rng.uniform(0, 0.002, size=(T, n)), axis=0)
    px = np.cumsum(rng.normal(0, 0.001, size=(T, n)), axis=0)
    holds = rng.random((T, n)) < 0.5
    pull_x, pull_y = rng.normal(0, 3, (T, n)), rng.normal(0, 3, (T, n))
    acc_y = rng.normal(0, 5, (T, n))
    t = np.arange(T) * 0.01
    acc = OutcomeAccumulator(n)
    for k in range(T):
        acc.update(t[k], mode[k], pull_x[k], pull_y[k], px[k], py[k], acc_y[k], holds[k])
    batch = acc.result()
    for i in range(n):
        tr = EpisodeTrace(time_s=t, mode=mode[:, i], grip_force_n=np.zeros(T), pull_force_x_n=pull_x[:, i],
                          pull_force_y_n=pull_y[:, i], object_position_x_m=px[:, i], object_position_y_m=py[:, i],
                          object_accel_y_m_s2=acc_y[:, i], receiver_holds=holds[:, i])
        ref = outcome_from_trace(tr)
        got = batch.episode(i)
        for f in ("released", "dropped", "handed_over", "mode_switch_count"):
            assert getattr(got, f) == getattr(ref, f), f
        for f in ("release_time_s", "drop_time_s", "force_overshoot_n", "slip_distance_m", "peak_down_accel_m_s2"):
            np.testing.assert_allclose(getattr(got, f), getattr(ref, f), rtol=1e-12, err_msg=f)


def test_same_seed_same_episode_bit_for_bit():
    cfg = quiet_config(sensors=SensorParams(ft_noise_std_n=0.05, ft_bias_std_n=0.1, accel_noise_snr_db=3.0,
                                            grip_noise_snr_db=3.0))
    a = run_episode(cfg, taking(0.3), ConstantGrip(8.0), seed=11).trace
    b = run_episode(cfg, taking(0.3), ConstantGrip(8.0), seed=11).trace
    c = run_episode(cfg, taking(0.3), ConstantGrip(8.0), seed=12).trace
    for f in fields(EpisodeTrace):
        va, vb = getattr(a, f.name), getattr(b, f.name)
        if isinstance(va, np.ndarray):
            assert va.tobytes() == vb.tobytes(), f.name
    assert a.sensed_force_y_n.tobytes() != c.sensed_force_y_n.tobytes()


def test_vectorised_plant_matches_scalar_plant():
    # Same equations on numpy arrays and on Python floats: noiseless runs agree.
    cfg = quiet_config(duration_s=2.5)
    behaviours = sample_behaviours("mixed", 8, np.random.default_rng(2), weight_n=cfg.obj.weight_n)
    batch = run_vectorised(cfg, stack_receivers(behaviours), ConstantGrip(7.0), seed=0)
    for i, b in enumerate(behaviours):
        ref = run_episode(cfg, b, ConstantGrip(7.0), seed=0).outcome
        got = batch.episode(i)
        for f in ("released", "dropped", "handed_over", "mode_switch_count"):
            assert getattr(got, f) == getattr(ref, f), (i, f)
        for f in ("release_time_s", "drop_time_s", "force_overshoot_n", "slip_distance_m", "peak_down_accel_m_s2"):
            np.testing.assert_allclose(getattr(got, f), getattr(ref, f), rtol=1e-6, atol=1e-9, err_msg=f"{i} {f}")


def test_batch_is_repeatable_and_independent_of_worker_count():
    cfg = quiet_config(duration_s=1.5, sensors=SensorParams(ft_noise_std_n=0.05, accel_noise_std_m_s2=0.5))
    factory = functools.partial(ConstantGrip, 8.0)
    one = run_batch(cfg, "mixed", 60, factory, seed=4, workers=1, chunk_size=20, progress=False)
    on_engine = functools.partial(run_tasks, workers=2, show_progress=False)  # a local Dask cluster
    two = run_batch(cfg, "mixed", 60, factory, seed=4, chunk_size=20, progress=False, map_tasks=on_engine)
    other = run_batch(cfg, "mixed", 20, factory, seed=5, workers=1, chunk_size=20, progress=False)
    for f in fields(one.outcome):
        a, b = getattr(one.outcome, f.name), getattr(two.outcome, f.name)
        assert a.tobytes() == b.tobytes(), f.name
    assert one.receivers.pull_angle_rad.tobytes() == two.receivers.pull_angle_rad.tobytes()
    assert one.receivers.pull_angle_rad[:20].tobytes() != other.receivers.pull_angle_rad.tobytes()
    # Chunk receivers are reproducible from the chunk's seed alone.
    seq = np.random.SeedSequence(4).spawn(3)[1]
    r = chunk_receivers("mixed", 20, seq, cfg.obj.weight_n)
    assert r.pull_angle_rad.tobytes() == one.receivers.pull_angle_rad[20:40].tobytes()


def test_batch_drop_rates_follow_the_physics():
    # Dropping receivers against an open-loop release drop; against a grip the receiver
    # cannot overcome (mu_s * 60 N = 36 N > 30 N max grasp strength) they never do.
    cfg = quiet_config(duration_s=3.5)
    rel = run_batch(cfg, "dropping", 24, functools.partial(ReleaseAfter, 10.0, 1.9), seed=1, workers=1, chunk_size=24,
                    progress=False)
    hold = run_batch(cfg, "dropping", 24, functools.partial(ConstantGrip, 60.0), seed=1, workers=1, chunk_size=24,
                     progress=False)
    assert rel.outcome.dropped.mean() > 0.9
    assert hold.outcome.dropped.sum() == 0 and hold.outcome.released.sum() == 0


def test_bad_inputs_raise_contact_sim_errors():
    from robot_sim.contact.config import ContactSimError, ObjectParams, SimConfig
    with pytest.raises(ContactSimError, match="mu_kinetic"):
        ObjectParams(mu_static=0.4, mu_kinetic=0.5)
    with pytest.raises(ContactSimError, match="dt_s"):
        SimConfig(dt_s=0.5)
    with pytest.raises(ContactSimError, match="unknown receiver behaviour"):
        sample_behaviours("juggling", 1, np.random.default_rng(0))
    with pytest.raises(ContactSimError, match="non-finite"):
        class Bad(ConstantGrip):
            def step(self, sample):
                return np.array([np.nan])
        run_episode(quiet_config(duration_s=0.1), dropping(), Bad(1.0))
