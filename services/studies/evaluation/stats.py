"""The report's statistics: rates with Wilson intervals, quantiles with distribution-free
order-statistic intervals (95 % by default).

- A rate k/n: scipy's `binomtest(k, n).proportion_ci(method="wilson")` (the Wilson score
  interval: sensible at 0/n and n/n, unlike the normal approximation).
- A quantile q (median, p95) of n values: the estimate is numpy's linear quantile; the
  interval is [X_(l), X_(u)] (order statistics, 1-based) with l = F⁻¹(α/2) and
  u = F⁻¹(1 − α/2) + 1 for F the Binomial(n, q) distribution: it covers the true quantile
  with probability ≥ 1 − α for any continuous distribution. With too few values a bound does
  not exist (the p95 of 8 values has no upper bound): it is None, and the report prints "—".
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class Rate:
    """k of n, its share and its interval (None when n = 0)."""

    k: int
    n: int
    share: float | None
    low: float | None
    high: float | None


@dataclass(frozen=True)
class Quantile:
    """A quantile of n values and its interval (a bound is None when n is too small)."""

    q: float
    n: int
    value: float | None
    low: float | None
    high: float | None


def wilson(k: int, n: int, confidence: float = 0.95) -> Rate:
    """The rate k/n with its Wilson score interval."""
    if not 0 <= k <= n:
        raise ValueError(f"need 0 <= k <= n, got k={k}, n={n}")
    if n == 0:
        return Rate(0, 0, None, None, None)
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    return Rate(k, n, k / n, float(ci.low), float(ci.high))


def order_statistic_ranks(n: int, q: float, confidence: float = 0.95) -> tuple[int | None, int | None]:
    """1-based ranks (l, u) of the order statistics bounding the q-quantile of n values; None
    for a bound that would fall outside 1..n."""
    alpha = 1.0 - confidence
    low = int(stats.binom.ppf(alpha / 2.0, n, q))
    high = int(stats.binom.ppf(1.0 - alpha / 2.0, n, q)) + 1
    return (low if low >= 1 else None), (high if high <= n else None)


def quantile(values: Sequence[float], q: float, confidence: float = 0.95) -> Quantile:
    """The q-quantile of `values` (NaN and None dropped) with its order-statistic interval."""
    x = np.sort(np.asarray([v for v in values if v is not None], dtype=float))
    x = x[np.isfinite(x)]
    if x.size == 0:
        return Quantile(q, 0, None, None, None)
    low, high = order_statistic_ranks(int(x.size), q, confidence)
    return Quantile(q, int(x.size), float(np.quantile(x, q)),
                    None if low is None else float(x[low - 1]), None if high is None else float(x[high - 1]))


def format_rate(rate: Rate) -> str:
    """``"62.5 % (30.6–86.3), 5/8"``, or ``"—"`` for no episodes."""
    if rate.share is None or rate.low is None or rate.high is None:
        return "— (0 episodes)"
    return f"{100 * rate.share:.1f} % ({100 * rate.low:.1f}–{100 * rate.high:.1f}), {rate.k}/{rate.n}"


def format_quantile(value: Quantile, scale: float = 1.0, digits: int = 2) -> str:
    """``"4.52 (4.31–4.80)"`` in the unit times `scale`; a one-sided interval (``"(≥ 4.31)"``)
    when one bound does not exist for this many values, none when neither does."""
    if value.value is None:
        return "— (no values)"
    text = f"{value.value * scale:.{digits}f}"
    if value.low is not None and value.high is not None:
        return f"{text} ({value.low * scale:.{digits}f}–{value.high * scale:.{digits}f})"
    if value.low is not None:
        return f"{text} (≥ {value.low * scale:.{digits}f})"
    if value.high is not None:
        return f"{text} (≤ {value.high * scale:.{digits}f})"
    return f"{text} (too few values for an interval)"
