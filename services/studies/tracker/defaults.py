"""Which tracker configuration to ship: candidates chosen on some seeds, confirmed on others.

`handover-study tracker-defaults` runs the evaluation (`services.studies.tracker.evaluate`,
hand error against the simulator's truth) for each `CANDIDATES` entry on the selection seeds,
takes the one with the lowest median error over all frames (p90 breaks a tie within 1 mm),
then runs every candidate again on the confirmation seeds, which played no part in the choice,
and says whether the choice still holds there. docs/tracker.md#defaults holds a run's tables.
"""

from __future__ import annotations

from services.studies.tracker.evaluate import PHASES, evaluate_episode, summarise
from services.tracker.config import TrackerConfig

#: Candidate configurations: the flags each sets over the base configuration.
CANDIDATES: dict[str, dict] = {
    "none": {"lag_correction": False, "proximity_filter": False},
    "lag (a) ≥ 0.35 m/s": {"lag_correction": True, "proximity_filter": False, "lag_min_speed_m_s": 0.35},
    "lag (a) ≥ 0.5 m/s": {"lag_correction": True, "proximity_filter": False, "lag_min_speed_m_s": 0.5},
    "lag (a) ≥ 0.7 m/s": {"lag_correction": True, "proximity_filter": False, "lag_min_speed_m_s": 0.7},
    "lag (a) ≥ 0.5 m/s, no surface offset": {"lag_correction": True, "proximity_filter": False,
                                             "lag_min_speed_m_s": 0.5, "lag_surface_offset_m": 0.0},
    "proximity (b)": {"lag_correction": False, "proximity_filter": True},
    "both (a)+(b) (the old default)": {"lag_correction": True, "proximity_filter": True, "lag_min_speed_m_s": 0.35},
}


def evaluate_candidates(seeds: range, base: TrackerConfig, progress: bool = False) -> dict:
    """The `summarise` table of every candidate over `seeds`."""
    from robot_sim.kinect import ArmGeometry

    arm = ArmGeometry()
    total: dict[str, dict[str, list[float]]] = {name: {p: [] for p in PHASES} for name in CANDIDATES}
    it = seeds
    if progress:
        from tqdm import tqdm

        it = tqdm(seeds, desc=f"seeds {seeds.start}–{seeds.stop - 1}", unit="ep")
    for seed in it:
        errs, _ = evaluate_episode(seed, base, arm, CANDIDATES)
        for name in CANDIDATES:
            for p in PHASES:
                total[name][p].extend(errs[name][p])
    return summarise(total)


def best(summary: dict) -> str:
    """The candidate with the lowest median error over all frames (p90 within 1 mm)."""
    ranked = sorted(summary, key=lambda n: (round(summary[n]["all"]["median_mm"]), summary[n]["all"]["p90_mm"]))
    return ranked[0]
