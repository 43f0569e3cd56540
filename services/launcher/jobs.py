"""The jobs of `handover-up` that use the bus (``handover``, ``demo``, and ``none``'s watch of
the supervisor): run one on the launcher's own bus node, and turn its result into the job's
outcome.

``handover`` follows the supervisor's episodes (`services.launcher.handover_job`); ``demo`` is
the joint-space demo (`services.launcher.demo`); ``none`` only watches the supervisor's
silence (`supervisor_watch_job`). The launcher says the outcome's summary lines
when the job succeeded, and takes its failure as the run's otherwise.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

from bus_schema import topics
from services.launcher.arm_stop import ArmStop
from services.runtime import Profile, ServiceNode

if TYPE_CHECKING:
    from services.launcher.demo import DemoResult
    from services.launcher.handover_job import JobResult

ResultT = TypeVar("ResultT")


@dataclass(frozen=True)
class JobOutcome:
    """How a bus job ended: `ok`, else `failure` (one line); `summary`: lines to say when ok."""

    ok: bool
    failure: str = ""
    summary: list[str] = field(default_factory=list)


def handover_outcome(result: JobResult) -> JobOutcome:
    """The handover job's outcome: a summary of the episodes' outcomes."""
    outcomes = ", ".join(r.summary.outcome for r in result.reports)
    return JobOutcome(result.ok, result.message,
                      [f"summary: {len(result.reports)} episode(s): {outcomes}; object never dropped"])


def demo_outcome(result: DemoResult) -> JobOutcome:
    """The demo's outcome: its summary lines, indented under ``summary:``."""
    return JobOutcome(result.ok, f"demo failed: {result.message}",
                      ["summary:", *("  " + line for line in result.lines)])


def handover_job_line(episodes: int) -> str:
    """The line that opens the handover job of `episodes` episodes (0: unlimited)."""
    return f"job: handover ({episodes or 'unlimited'} episode{'s' if episodes != 1 else ''})"


def robot_line() -> str:
    """The line that names the run's arm (the profile's ``[robot]``, or ``--robot``)."""
    from handover_model import robots

    arm = robots.active()
    return f"robot: {arm.name} ({arm.title})"


def handover_job(episodes: int, episode_timeout_s: float, abort_reason: Callable[[], str | None],
                 say: Callable[[str], None], supervisor_pid: Callable[[], int | None] | None,
                 delivery_pids: tuple[int, ...]) -> Callable[[ServiceNode], JobOutcome]:
    """The handover job, to run with `run_on_bus` (arguments: `handover_job.run_handover_job`'s).
    Its stop goes through the node's one ``motion/stop`` publisher, which the monitor's
    `ArmStop` was given too (`ServiceNode.publisher`: one per topic)."""
    from services.launcher.handover_job import run_handover_job

    def run(node: ServiceNode) -> JobOutcome:
        say(robot_line())
        say(handover_job_line(episodes))
        return handover_outcome(run_handover_job(node, episodes, abort_reason, say, episode_timeout_s,
                                                 supervisor_pid, delivery_pids))

    return run


def supervisor_watch_job(abort_reason: Callable[[], str | None], say: Callable[[str], None],
                         supervisor_pid: Callable[[], int | None] | None,
                         delivery_pids: tuple[int, ...]) -> Callable[[ServiceNode], JobOutcome]:
    """The ``none`` job's watch of the supervisor, to run with `run_on_bus`: the handover job's
    judgement of a silent supervisor (and its protective stop), without following the
    episodes. Nothing else sees a frozen supervisor (its liveliness token stays up)."""
    from services.launcher.handover_job import run_handover_job

    def run(node: ServiceNode) -> JobOutcome:
        result = run_handover_job(node, 0, abort_reason, say, supervisor_pid=supervisor_pid,
                                  delivery_pids=delivery_pids, follow_episodes=False)
        return JobOutcome(result.ok, result.message)

    return run


def demo_job(abort_reason: Callable[[], str | None], say: Callable[[str], None]) -> Callable[[ServiceNode], JobOutcome]:
    """The joint-space demo, to run with `run_on_bus`."""
    from services.launcher.demo import run_demo

    def run(node: ServiceNode) -> JobOutcome:
        say(robot_line())
        say("job: joint-space demo")
        return demo_outcome(run_demo(node, abort_reason))

    return run


def run_on_bus(bus_profile: Profile, stop_requested: threading.Event, job: Callable[[ServiceNode], ResultT],
               arm_stop: ArmStop | None = None) -> ResultT:
    """Run `job` on a bus node of the launcher's own (``launcher``, on `bus_profile`), which
    stops once `stop_requested` is set. `arm_stop`: given a ``motion/stop`` publisher of that
    node while the job runs (the monitor thread's protective stop)."""
    # No heartbeat: nothing watches the launcher's (its login may not even publish one).
    with ServiceNode("launcher", bus_profile, install_signal_handlers=False, clock_role="observer",
                     heartbeat=False) as node:
        def stop_when_asked() -> None:
            stop_requested.wait()
            node.request_stop()

        threading.Thread(target=stop_when_asked, daemon=True).start()
        if arm_stop is not None:
            arm_stop.attach(node.publisher(topics.MOTION_STOP))
        try:
            return job(node)
        finally:
            if arm_stop is not None:
                arm_stop.detach()
