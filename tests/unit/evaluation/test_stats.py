"""The report's statistics: Wilson intervals, order-statistic intervals, the summary's groups."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as sps

from services.studies.evaluation.stats import format_quantile, order_statistic_ranks, quantile, wilson
from services.studies.evaluation.summary import as_expected, height_band, summarise


def _wilson_by_formula(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half, centre + half


@pytest.mark.parametrize("k, n", [(0, 8), (3, 8), (8, 8), (412, 500)])
def test_wilson_matches_the_textbook_formula(k, n):
    rate = wilson(k, n)
    low, high = _wilson_by_formula(k, n)
    assert rate.share == k / n
    assert rate.low == pytest.approx(max(0.0, low), abs=1e-9) and rate.high == pytest.approx(min(1.0, high), abs=1e-9)


def test_no_episodes_is_no_rate_and_impossible_counts_are_refused():
    assert wilson(0, 0).share is None
    with pytest.raises(ValueError):
        wilson(5, 3)


def test_order_statistic_intervals_cover_the_quantile_at_least_95_percent():
    """The coverage of [X_(l), X_(u)] is P(l <= B < u), B ~ Binomial(n, q): at least 95 %."""
    for n in (20, 60, 500):
        for q in (0.5, 0.95):
            low, high = order_statistic_ranks(n, q)
            if low is None or high is None:
                continue
            coverage = sps.binom.cdf(high - 1, n, q) - sps.binom.cdf(low - 1, n, q)
            assert coverage >= 0.95 - 1e-9, (n, q, low, high, coverage)


def test_an_empirical_coverage_check_on_a_skewed_distribution():
    rng = np.random.default_rng(1)
    true_median = math.log(2.0)  # exponential(1)
    hits = sum(1 for _ in range(400) if (m := quantile(rng.exponential(1.0, 40), 0.5)).low <= true_median <= m.high)
    assert hits / 400 >= 0.92


def test_too_few_values_give_one_sided_or_no_intervals():
    q = quantile([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], 0.95)
    assert q.value == pytest.approx(np.quantile(np.arange(1, 9), 0.95)) and q.high is None and q.low is not None
    assert format_quantile(q).endswith(f"(≥ {q.low:.2f})")
    assert format_quantile(quantile([3.0], 0.5)) == "3.00 (too few values for an interval)"
    assert quantile([None, float("nan")], 0.5).value is None


def _record(k, behaviour="taking", success=True, dropped=False, stops=(), height=1.7, posture="standing", t=5.0):
    return {"episode": k, "seed": k, "behaviour": behaviour, "posture": posture, "height_m": height,
            "outcome": "released" if success else "timeout", "success": success, "dropped": dropped,
            "protective_stops": list(stops), "time_to_handover_s": t if success else None, "reason": "",
            "criteria": {"plan": True, "reach": None if behaviour == "absent" else success, "stability": not dropped,
                         "affordance": None, "safe": True}}


def test_the_summary_counts_groups_and_failing_episodes():
    records = [_record(0), _record(1, success=False), _record(2, "absent", success=False, height=1.5),
               _record(3, "dropping", success=False, dropped=True, posture="sitting", height=1.9),
               _record(4, "bumping", success=False, stops=["protective stop: tracker silent"])]
    f = summarise(records)
    assert (f["success"].k, f["success"].n) == (1, 5)
    assert (f["as_expected"].k, f["dropped"].k, f["false_stop"].k) == (2, 1, 1)
    assert [r["episode"] for r in f["failing"]] == [1, 3, 4]
    assert f["stop_reasons"] == {"protective stop: tracker silent": 1}
    assert list(f["by_height"]) == ["< 1.60 m", "1.60–1.75 m", "≥ 1.75 m"]
    assert (f["by_behaviour"]["taking"]["success"].k, f["by_behaviour"]["taking"]["success"].n) == (1, 2)
    assert (f["criteria"]["reach"].k, f["criteria"]["reach"].n) == (1, 4)  # absent: not defined
    assert f["criteria"]["affordance"].n == 0
    assert f["quantities"]["time_to_handover_s"]["median"].value == 5.0
    assert as_expected(_record(9, "absent", success=False)) and height_band(1.75) == "≥ 1.75 m"
