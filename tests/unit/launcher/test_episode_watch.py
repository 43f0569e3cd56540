"""The handover job's reading of the episodes (services/launcher/episode_watch.py): the outcome
of a dropped object comes from the simulation's truth, and only the supervisor's first summary
of an episode counts (issue 17)."""

from __future__ import annotations

from bus_schema.messages import EpisodeSummary, SimTruth, SupervisorState
from services.launcher.episode_watch import EpisodeWatch

H = {"seq": 0, "stamp_ns": 1}


def _summary(episode: int, outcome: str = "released", source: str = "supervisor") -> EpisodeSummary:
    return EpisodeSummary(**H, source=source, episode_id=episode, outcome=outcome, reason="released to the receiver")


def _state(episode: int, phase: str) -> SupervisorState:
    return SupervisorState(**H, source="supervisor", episode_id=episode, phase=phase)


def test_a_drop_in_the_truth_fails_the_episode_whatever_the_summary_says():
    watch = EpisodeWatch()
    watch.state(_state(1, "transfer"))
    watch.truth(SimTruth(**H, source="bridge", held_by="none", dropped=True))
    report = watch.summary(_summary(1))
    assert report.dropped and not report.ok
    assert any("DROPPED" in line for line in report.lines)
    # The next episode starts clean.
    watch.state(_state(2, "transfer"))
    watch.truth(SimTruth(**H, source="bridge", held_by="receiver"))
    assert watch.summary(_summary(2)).ok


def test_only_the_supervisors_first_summary_of_an_episode_counts():
    watch = EpisodeWatch()
    assert not watch.accepts(_summary(1, source="planner"))  # anyone else: never
    assert watch.accepts(_summary(1))
    watch.summary(_summary(1))
    assert not watch.accepts(_summary(1))  # a copy: the first one stands
    assert watch.accepts(_summary(2))


def test_released_is_not_ok_when_the_truth_has_the_object_elsewhere():
    watch = EpisodeWatch()
    watch.state(_state(1, "transfer"))
    watch.truth(SimTruth(**H, source="bridge", held_by="gripper"))
    assert not watch.summary(_summary(1)).ok
