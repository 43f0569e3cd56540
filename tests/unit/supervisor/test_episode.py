"""One episode's record: goal ids, goals sent again, the summary's bounds."""

from __future__ import annotations

import numpy as np
import pytest

from bus_schema.messages import MotionStatus
from services.supervisor.episode import Episode

H = {"seq": 0, "stamp_ns": 0, "source": "test"}


def test_each_goal_has_its_own_id_and_is_sent_again_until_motion_reports_on_it():
    ep = Episode(3, 0.0)
    first = ep.new_goal("pick", 1.0, position_base_m=(0.1, 0.2, 0.3))
    assert first == {"goal_id": "e3-pick-1", "kind": "pick", "position_base_m": (0.1, 0.2, 0.3)}
    assert ep.new_goal("pick", 2.0)["goal_id"] == "e3-pick-2" and ep.goal_sent_s == 2.0
    assert ep.goal_to_repeat(None, 2.05, 0.1) is None  # not yet
    again = ep.goal_to_repeat(None, 2.1, 0.1)
    assert again == {"goal_id": "e3-pick-2", "kind": "pick"} and ep.goal_repeats == 1
    other = MotionStatus(**H, goal_id="e3-pick-1", state="reached")
    assert ep.goal_status(other) is None  # a report on an older goal says nothing of this one
    assert ep.goal_to_repeat(other, 2.3, 0.1) is not None
    reported = MotionStatus(**H, goal_id="e3-pick-2", state="moving")
    assert ep.goal_status(reported) == "moving"
    assert ep.goal_to_repeat(reported, 2.5, 0.1) is None and ep.goal_unacknowledged is None
    assert ep.goal_to_repeat(None, 3.0, 0.1) is None  # for good


def test_the_summary_is_bounded_to_the_schema_and_names_only_known_postures():
    ep = Episode(1, 0.0, outcome="released", outcome_reason="r" * 600, receiver_posture="kneeling",
                 faults=["f" * 600] * 40, reach_position_m=np.array([0.45, -0.26, 0.3]),
                 transfer_start_grip_n=9.0, peak_grip_n=8.0)
    ep.add_time("reach", 1.0)
    ep.add_time("reach", 0.5)
    ep.add_time("transfer", 1e6)
    s = ep.summary()
    assert len(s["reason"]) == 512 and s["receiver_posture"] == "unknown"
    assert len(s["faults"]) == 32 and all(len(f) == 512 for f in s["faults"])
    assert s["phase_durations_s"] == {"reach": pytest.approx(1.5), "transfer": 86400.0}
    assert s["transfer_point_base_m"] == (0.45, -0.26, 0.3) and s["force_overshoot_n"] == 0.0
