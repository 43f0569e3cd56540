"""The evaluation's figures from the per-episode records (pure; the report prints them).

Definitions (each episode's fields: `record`):

- success: released, into the receiver's hand by the simulation's truth, never dropped;
- as expected: a taking receiver got the object (success); any other receiver (dropping,
  hesitating, bumping, absent) did not make the object fall and caused no protective stop:
  the robot kept it or let it go safely;
- dropped: the simulation's truth saw the object fall;
- false stop: a protective stop in an episode with no fault injected (none is, in an
  evaluation): every protective stop is a false one;
- a failing episode: not as expected, or a stack that produced no summary.
Times are over the successful episodes; the near-hand speed over every episode with truth.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

from services.studies.evaluation.stats import Quantile, Rate, quantile, wilson

#: Height bands of the report, m (lower edges; the last band is open).
HEIGHT_BANDS_M = (0.0, 1.60, 1.75)
#: Quantities reported as median and p95: (record field, label, unit, scale, which episodes).
QUANTITIES: tuple[tuple[str, str, str, float, str], ...] = (
    ("time_to_handover_s", "time to handover (episode start → release)", "s", 1.0, "successful"),
    ("reach_to_release_s", "reach start → release", "s", 1.0, "successful"),
    ("transfer_point_error_m", "transfer point vs DJT optimum of the true receiver", "cm", 100.0, "all"),
    ("peak_speed_near_hand_before_release_m_s", "arm speed within 0.3 m of the hand, before release", "m/s", 1.0,
     "all"),
    ("peak_speed_near_hand_after_release_m_s", "arm speed within 0.3 m of the hand, after release", "m/s", 1.0,
     "successful"),
    ("min_tool_hand_distance_m", "closest tool → hand distance", "cm", 100.0, "all"),
    ("peak_grip_force_n", "peak grip force", "N", 1.0, "all"),
    ("force_overshoot_n", "grip force overshoot", "N", 1.0, "all"),
    ("release_to_rest_s", "release → arm at rest", "ms", 1000.0, "successful"),
    ("wall_s", "wall time per episode (start-up and shutdown included)", "s", 1.0, "all"),
)
CRITERIA = ("plan", "reach", "stability", "affordance", "safe")


def as_expected(record: dict[str, Any]) -> bool:
    """Whether the stack did what it should with this receiver (module docstring)."""
    if record.get("outcome") in ("stack_error", "no_summary"):
        return False
    if record.get("behaviour") == "taking":
        return bool(record.get("success"))
    return not record.get("dropped") and not record.get("protective_stops")


def height_band(height_m: float) -> str:
    edges = HEIGHT_BANDS_M
    for low, high in zip(edges, (*edges[1:], None), strict=True):
        if high is None or height_m < high:
            return f"≥ {low:.2f} m" if high is None else (f"< {high:.2f} m" if low == 0.0 else
                                                          f"{low:.2f}–{high:.2f} m")
    raise AssertionError("unreachable")


def group_order(name: str) -> tuple[float, str]:
    """Sort key of a group name: height bands by their lower edge, other names alphabetically."""
    for i, low in enumerate(HEIGHT_BANDS_M):
        if name == height_band(low + 1e-9):
            return (float(i), name)
    return (0.0, name)


def _rate(records: Sequence[dict[str, Any]], test: Callable[[dict[str, Any]], bool]) -> Rate:
    return wilson(sum(1 for r in records if test(r)), len(records))


def _group_rates(records: Sequence[dict[str, Any]], key: Callable[[dict[str, Any]], str]) -> dict[str, dict[str, Rate]]:
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        groups.setdefault(key(r), []).append(r)
    return {name: {"success": _rate(rs, lambda r: bool(r.get("success"))),
                   "as_expected": _rate(rs, as_expected),
                   "dropped": _rate(rs, lambda r: bool(r.get("dropped")))}
            for name, rs in sorted(groups.items(), key=lambda item: group_order(item[0]))}


def _criteria(records: Sequence[dict[str, Any]]) -> dict[str, Rate]:
    out = {}
    for name in CRITERIA:
        defined = [r for r in records if (r.get("criteria") or {}).get(name) is not None]
        out[name] = _rate(defined, lambda r, n=name: bool(r["criteria"][n]))
    return out


def summarise(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Every figure of the report, from the records (see the module docstring)."""
    successful = [r for r in records if r.get("success")]
    ran = [r for r in records if r.get("outcome") != "stack_error"]
    quantities: dict[str, dict[str, Quantile]] = {}
    for field, _label, _unit, _scale, which in QUANTITIES:
        values = [r.get(field) for r in (successful if which == "successful" else ran)]
        quantities[field] = {"median": quantile(values, 0.5), "p95": quantile(values, 0.95)}
    stop_reasons = Counter(reason for r in records for reason in r.get("protective_stops") or [])
    return {
        "episodes": len(records),
        "outcomes": dict(sorted(Counter(str(r.get("outcome")) for r in records).items())),
        "success": _rate(records, lambda r: bool(r.get("success"))),
        "as_expected": _rate(records, as_expected),
        "dropped": _rate(records, lambda r: bool(r.get("dropped"))),
        "false_stop": _rate(records, lambda r: bool(r.get("protective_stops"))),
        "stop_reasons": dict(stop_reasons.most_common()),
        "by_behaviour": _group_rates(records, lambda r: str(r.get("behaviour"))),
        "by_posture": _group_rates(records, lambda r: str(r.get("posture"))),
        "by_height": _group_rates(records, lambda r: height_band(float(r["height_m"]))),
        "criteria": _criteria(records),
        "quantities": quantities,
        "failing": [r for r in records if not as_expected(r)],
    }
