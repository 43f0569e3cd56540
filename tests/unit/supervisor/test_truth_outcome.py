"""The episode outcome from the simulation's truth (services/supervisor/truth.py, issue 17)."""

from __future__ import annotations

from bus_schema.messages import SimTruth
from services.supervisor.truth import outcome_from_truth

H = {"seq": 0, "stamp_ns": 1, "source": "bridge"}
RELEASED = {"episode_id": 3, "outcome": "released", "reason": "released to the receiver", "replans": 0}


def test_a_fallen_object_makes_the_episode_dropped_whatever_the_bus_said():
    out = outcome_from_truth(RELEASED, SimTruth(**H, held_by="none", dropped=True))
    assert out["outcome"] == "dropped"
    assert out["reason"] == ("the object fell (simulation truth); the supervisor saw released: released to "
                             "the receiver")
    assert {k: v for k, v in out.items() if k not in ("outcome", "reason")} == {"episode_id": 3, "replans": 0}
    assert RELEASED["outcome"] == "released"  # the input is not changed


def test_without_truth_or_without_a_drop_the_sequencers_verdict_stands():
    assert outcome_from_truth(RELEASED, None) == RELEASED  # hardware: no truth
    assert outcome_from_truth(RELEASED, SimTruth(**H, held_by="receiver")) == RELEASED
    long = {**RELEASED, "reason": "x" * 600}
    assert len(outcome_from_truth(long, SimTruth(**H, held_by="none", dropped=True))["reason"]) == 512


def test_released_only_when_the_receiver_holds_the_object():
    """A release event forged with the gripper's login: the truth still has the object in the gripper."""
    out = outcome_from_truth(RELEASED, SimTruth(**H, held_by="gripper"))
    assert out["outcome"] == "failed"
    assert out["reason"].startswith("not released: the simulation truth has the object held by gripper")
    timeout = {**RELEASED, "outcome": "timeout", "reason": "the receiver did not take the object within 6 s"}
    assert outcome_from_truth(timeout, SimTruth(**H, held_by="gripper")) == timeout  # kept the object: fine


def test_truth_is_read_only_where_the_robot_is_simulated():
    from services.runtime.profile import load_profile_file
    from services.supervisor.truth import simulated_robot

    assert simulated_robot(load_profile_file("sim")) and simulated_robot(load_profile_file("baxter_fake"))
    assert not simulated_robot(load_profile_file("baxter")) and not simulated_robot(load_profile_file("multihost"))
