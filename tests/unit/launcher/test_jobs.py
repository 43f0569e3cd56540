"""The bus jobs' outcomes (services/launcher/jobs.py): the lines the launcher says when a job
succeeded and the failure it takes when not."""

from __future__ import annotations

from bus_schema.messages import EpisodeSummary
from services.launcher.demo import DemoResult
from services.launcher.episode_watch import EpisodeReport
from services.launcher.handover_job import JobResult
from services.launcher.jobs import demo_outcome, handover_job_line, handover_outcome


def _report(episode: int, outcome: str) -> EpisodeReport:
    summary = EpisodeSummary(seq=0, stamp_ns=1, source="supervisor", episode_id=episode, outcome=outcome, reason="r")
    return EpisodeReport(summary, dropped=False, final_holder=None, lines=[])


def test_the_handover_summary_lists_every_episodes_outcome():
    outcome = handover_outcome(JobResult(True, "", [_report(1, "released"), _report(2, "timeout")]))
    assert outcome.ok
    assert outcome.summary == ["summary: 2 episode(s): released, timeout; object never dropped"]


def test_a_failed_handover_job_carries_its_message():
    outcome = handover_outcome(JobResult(False, "episode 1: the object was dropped"))
    assert not outcome.ok and outcome.failure == "episode 1: the object was dropped"


def test_the_demo_summary_is_its_lines_indented_and_its_failure_names_the_demo():
    outcome = demo_outcome(DemoResult(ok=True, lines=["commands sent: 10", "final error 0.001 rad"]))
    assert outcome.ok and outcome.summary == ["summary:", "  commands sent: 10", "  final error 0.001 rad"]
    assert demo_outcome(DemoResult(ok=False, message="no joint state")).failure == "demo failed: no joint state"


def test_the_handover_job_line_counts_the_episodes():
    assert handover_job_line(1) == "job: handover (1 episode)"
    assert handover_job_line(3) == "job: handover (3 episodes)"
    assert handover_job_line(0) == "job: handover (unlimited episodes)"
