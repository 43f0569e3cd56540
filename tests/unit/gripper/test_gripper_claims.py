"""The thesis-claims table of `handover-study reproduce`, on hand-made episode metrics."""

from __future__ import annotations

import math
from dataclasses import replace

from services.studies.gripper.claims import Claim, EpisodeMetrics, claims_table, simulation_claims

HELD = EpisodeMetrics(
    release_time_s=math.nan, final_mode="grasp", released_at_end=False, pull_at_release_n=math.nan,
    max_accel_y_m_s2=2.0, max_accel_y_slipping_m_s2=1.0, min_accel_y_after_release_m_s2=math.nan,
    accel_before_release=True, mode_switches=2, first_slip_time_s=1.5, slide_m=0.3, final_grip_n=10.0,
    initial_grip_n=12.0,
)
RELEASED = EpisodeMetrics(
    release_time_s=1.1, final_mode="release", released_at_end=True, pull_at_release_n=0.8,
    max_accel_y_m_s2=3.0, max_accel_y_slipping_m_s2=0.0, min_accel_y_after_release_m_s2=-1.0,
    accel_before_release=True, mode_switches=1, first_slip_time_s=math.nan, slide_m=0.0, final_grip_n=0.0,
    initial_grip_n=12.0,
)


def _metrics(dropping: EpisodeMetrics = HELD) -> dict[int, dict[str, EpisodeMetrics]]:
    low_mu_drop = replace(HELD, max_accel_y_slipping_m_s2=2.5)
    return {
        20: {"taking": RELEASED, "dropping": dropping},
        21: {"taking_phi_p20": RELEASED, "taking_phi_m20": RELEASED},
        22: {"taking_high_mu": RELEASED, "dropping_high_mu": HELD, "taking_low_mu": RELEASED,
             "dropping_low_mu": low_mu_drop},
        23: {"dropping_grip_noise": HELD, "dropping_accel_noise": HELD, "dropping_grip_noise_variance": HELD},
    }


def test_simulation_claims_in_figure_order_tagged_with_the_preset():
    claims = simulation_claims(_metrics(), "FS-sim-g5")
    assert [c.source for c in claims] == [
        f"{s} [FS-sim-g5]" for s in ("Fig. 20a", "Fig. 20b,d", "Fig. 20c", "Fig. 21", "Fig. 22", "Fig. 23a,c",
                                     "Fig. 23a,c (SNR vs variance)", "Fig. 23b,d")
    ]
    assert all(c.agree == "yes" for c in claims)
    assert "released at t = 1.10 s (pull started at 1 s), F_p then 0.80 N" in claims[0].ours
    assert "slides 0.30 m" in claims[1].note


def test_dropping_that_never_slips_disagrees_and_says_why():
    never_slips = replace(HELD, first_slip_time_s=math.nan)
    claim = simulation_claims(_metrics(never_slips), "FS-sim-g1")[1]
    assert claim.agree == "no"
    assert "slip from never" in claim.ours
    assert claim.note.startswith("the pull (2 N) stays below F_ST(0) = ")


def test_claims_table_one_row_per_claim_with_pipes_escaped():
    claims = [Claim("§3.4.4", "the pole |a| ≤ 1", "|a| = 0.5", "yes"), Claim("§3.5", "t", "o", "no", "n")]
    table = claims_table(claims)
    assert table.splitlines() == [
        "| where | thesis states | we get | agree | note |", "|---|---|---|---|---|",
        "| §3.4.4 | the pole \\|a\\| ≤ 1 | \\|a\\| = 0.5 | yes |  |", "| §3.5 | t | o | no | n |",
    ]
