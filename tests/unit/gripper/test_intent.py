"""The intent features, the logistic model and the study (services/studies/gripper/intent_*.py)."""

from __future__ import annotations

import numpy as np
import pytest

from services.gripper.errors import GripperError
from services.studies.gripper.intent_features import FEATURE_NAMES, IntentFeatures, IntentModel
from services.studies.gripper.intent_study import FeatureSet, accuracy_table, collect, fit
from services.studies.gripper.oracle_family import bench_chunks
from tests.unit.gripper.helpers import sample


def test_features_capture_the_force_change_at_each_lag_after_the_onset():
    f = IntentFeatures(2)
    f.update(sample(0.0, fy=2.0, n=2))  # W0 = 2 N; onset threshold 0.5 + 0.2 = 0.7 N
    f.update(sample(0.01, fx=[0.5, 0.0], fy=2.0, n=2))  # below the threshold: no onset
    assert np.isnan(f.onset_s).all()
    f.update(sample(0.02, fx=[1.0, 0.0], fy=2.0, n=2))  # episode 0: |ΔF| = 1 N, onset at 0.02 s
    assert f.onset_s[0] == pytest.approx(0.02) and np.isnan(f.onset_s[1])
    for k, t in enumerate(np.arange(0.03, 0.13, 0.01)):
        f.update(sample(t, fx=[2.0, 0.0], fy=[1.0 - 0.05 * k, 2.0], vx=[0.01, 0.3], n=2))
    vals = dict(zip(FEATURE_NAMES, f.values[0]))
    assert vals["dfx_w_20ms"] == pytest.approx(1.0)  # t = 0.04 s
    assert vals["dfy_w_20ms"] == pytest.approx((0.95 - 2.0) / 2.0)
    assert vals["dfy_w_50ms"] == pytest.approx((1.0 - 0.05 * 4 - 2.0) / 2.0)  # t = 0.07 s
    assert f.decided.tolist() == [True, False] and vals["slip_max_m_s"] == pytest.approx(0.01)
    assert np.isnan(f.values[1]).all()  # never touched: nothing captured, the gate never decides


def test_model_probability_and_validation():
    d = len(FEATURE_NAMES)
    m = IntentModel(tuple([1.0] + [0.0] * (d - 1)), 0.0, tuple([0.0] * d), tuple([2.0] * d))
    p = m.probability(np.array([[2.0] + [0.0] * (d - 1), [0.0] * d]))
    np.testing.assert_allclose(p, [1 / (1 + np.exp(-1.0)), 0.5])
    with pytest.raises(GripperError, match="scales > 0"):
        IntentModel(tuple([1.0] * d), 0.0, tuple([0.0] * d), tuple([0.0] * d))
    with pytest.raises(GripperError, match="need"):
        IntentModel((1.0,), 0.0, (0.0,), (1.0,))


def test_model_save_load_round_trip(tmp_path):
    d = len(FEATURE_NAMES)
    m = IntentModel(tuple(np.linspace(-1, 1, d)), 0.3, tuple([0.1] * d), tuple([1.5] * d), 0.6, {"seed": 1000})
    back = IntentModel.load(m.save(tmp_path / "m.json"))
    assert back == m
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(GripperError, match="cannot read the intent model"):
        IntentModel.load(tmp_path / "bad.json")


def test_fit_separates_separable_data_and_scores_it():
    rng = np.random.default_rng(0)
    n, d = 400, len(FEATURE_NAMES)
    taking = rng.random(n) < 0.5
    x = rng.normal(size=(n, d))
    x[:, 1] += np.where(taking, -3.0, 3.0)  # ΔF_y/W0 at 20 ms: a lift
    data = FeatureSet(x, np.ones(n, bool), taking, np.where(taking, 0, 1), np.full(n, "slow"), np.zeros(n))
    model = fit(data)
    rows = {r["kind"]: r for r in accuracy_table(model, data)}
    assert rows["all"]["accuracy"] > 0.99 and model.weights[1] < 0  # unloading means taking


def test_fit_needs_both_classes():
    n, d = 10, len(FEATURE_NAMES)
    data = FeatureSet(np.zeros((n, d)), np.ones(n, bool), np.ones(n, bool), np.zeros(n, int), np.full(n, "slow"),
                      np.zeros(n))
    with pytest.raises(GripperError, match="both"):
        fit(data)


def test_on_the_plant_bumps_are_told_apart_and_every_taker_has_an_onset():
    data = collect(bench_chunks(1000, 48, 24, "wide"))
    assert data.decided[data.taking].all()
    bump, taking = data.kind == 2, data.taking
    assert (data.x[bump, 0] < 0).all() and (data.x[taking, 0] > 0).all()  # ΔF_x at 20 ms: a push vs a pull
