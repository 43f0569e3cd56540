"""`handover-study tracker-defaults`: the choice rule and the refusal of overlapping seed sets.
(The sweep itself runs in seconds per episode: two episodes per set here, enough to check that
every candidate is measured and that "(b) on" loses to "(b) off", as the full run says.)"""

from __future__ import annotations

from services.studies.cli import main
from services.studies.tracker.defaults import CANDIDATES, best, evaluate_candidates
from services.tracker.config import TrackerConfig


def row(median: float, p90: float) -> dict:
    return {"all": {"median_mm": median, "p90_mm": p90}}


def test_the_lowest_median_wins_and_p90_breaks_a_tie_within_a_millimetre():
    assert best({"a": row(55.0, 90.0), "b": row(54.2, 120.0)}) == "b"
    assert best({"a": row(54.4, 99.0), "b": row(53.6, 101.0)}) == "a"  # both round to 54: p90 decides


def test_overlapping_seed_sets_are_refused(capsys):
    assert main(["tracker-defaults", "--episodes", "16", "--select-seed", "0", "--confirm-seed", "8"]) == 2
    assert "overlap" in capsys.readouterr().err


def test_every_candidate_is_measured_and_the_proximity_filter_loses():
    summary = evaluate_candidates(range(0, 2), TrackerConfig())
    assert set(summary) == set(CANDIDATES)
    assert summary["proximity (b)"]["all"]["median_mm"] > summary["none"]["all"]["median_mm"] + 20.0
    assert best(summary) != "proximity (b)" and best(summary) != "both (a)+(b) (the old default)"
