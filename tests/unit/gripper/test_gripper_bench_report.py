"""The benchmark's reports (tables and CSV) on hand-made figures."""

from __future__ import annotations

import csv
import math

from dataclasses import replace

from services.studies.gripper.bench_report import attribution_table, markdown_table, subpopulation_table, write_csv
from services.studies.gripper.benchmark import ControllerStats, SubpopulationStats

BY_BEHAVIOUR = {"taking": 0.0, "dropping": 0.25, "hesitating": math.nan, "bumping": 0.5}
STATS = ControllerStats(
    controller="SG", episodes=8, drops=2, drop_rate=0.25, drop_ci=(0.07, 0.59), taking_episodes=3,
    release_success_rate=1.0, release_success_ci=(0.44, 1.0), overshoot_median_n=4.5, overshoot_p95_n=math.nan,
    release_time_median_s=0.4567, mode_switches_mean=1.25, drop_rate_by_behaviour=BY_BEHAVIOUR,
)


def test_headline_row_in_percent_with_a_dash_for_missing_figures():
    lines = markdown_table([STATS]).splitlines()
    assert len(lines) == 3 and lines[1] == "|---|---|---|---|---|---|---|"
    assert lines[2] == ("| SG | 25.0 [7.0, 59.0] | 100.0 [44.0, 100.0] | 4.50 / – | 0.457 | 1.25 "
                        "| 0.0 / 25.0 / – / 50.0 |")


def test_attribution_row_in_percent_of_all_episodes():
    row = {"controller": "HI", "drop_rate": 0.3, "unavoidable_rate": 0.05, "actuator_limited_rate": 0.1,
           "receiver_let_go_rate": 0.0, "controller_drop_rate": 0.15, "controller_drop_ci": (0.1, 0.2),
           **{f"controller_drop_rate_{k}": v for k, v in BY_BEHAVIOUR.items()}}
    lines = attribution_table([row]).splitlines()
    assert len(lines) == 3
    assert lines[2] == "| HI | 30.0 | 5.0 | 10.0 | 0.0 | 15.0 [10.0, 20.0] | 0.0 / 25.0 / – / 50.0 |"


def test_csv_has_one_row_per_controller_with_the_behaviour_columns(tmp_path):
    path = write_csv([STATS, STATS], tmp_path / "sub" / "results.csv")
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 and rows[0]["controller"] == "SG" and rows[0]["drop_ci_high"] == "0.59"
    assert list(rows[0])[-4:] == [f"drop_rate_{k}" for k in BY_BEHAVIOUR]


def test_sub_population_rows_in_percent_with_dashes_where_nobody_takes():
    taking = SubpopulationStats("taking, drag (never lifts)", "fast (500 N/s, 250 Hz)",
                                replace(STATS, handed_over=3, held_to_end=0))
    bumps = SubpopulationStats("bumping", "slow (50 N/s, 25 Hz)", replace(
        STATS, taking_episodes=0, handed_over=0, release_success_rate=math.nan,
        release_success_ci=(math.nan, math.nan), overshoot_median_n=math.nan, release_time_median_s=math.nan))
    lines = subpopulation_table([taking, bumps]).splitlines()
    assert len(lines) == 4 and lines[1] == "|" + "---|" * 10
    assert lines[2] == ("| taking, drag (never lifts) | fast (500 N/s, 250 Hz) | SG | 8 | 2 | 25.0 [7.0, 59.0] "
                        "| 3 / 0 / 3 | 100.0 [44.0, 100.0] | 4.50 / – | 0.457 |")
    assert lines[3] == "| bumping | slow (50 N/s, 25 Hz) | SG | 8 | 2 | 25.0 [7.0, 59.0] | – | – | – | – |"
