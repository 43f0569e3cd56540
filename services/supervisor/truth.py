"""The episode's outcome from the simulation's truth (issue 17, item 6).

In simulation the bridge publishes where the object really is (`sim/truth`); never used for
control, it decides the summary's outcome when it says the object fell: whatever the bus
said (a release event, a grip state), a dropped object is a ``dropped`` episode, and an
episode is ``released`` only if the receiver holds the object. On hardware there is no truth
and the summary is the sequencer's.
"""

from __future__ import annotations

from typing import Any

from bus_schema.messages import SimTruth
from services.runtime.profile import Profile


def outcome_from_truth(summary: dict[str, Any], truth: SimTruth | None) -> dict[str, Any]:
    """`summary` (EpisodeSummary fields) as `truth` (the newest `sim/truth`, or None) has it:
    ``dropped`` when the object fell; ``failed`` when the sequencer says ``released`` but the
    receiver does not hold the object. The sequencer's verdict stays in the reason."""
    if truth is None or summary.get("outcome") == "dropped":
        return summary
    saw = f"the supervisor saw {summary.get('outcome')}: {summary.get('reason', '')}"
    if truth.dropped:
        return {**summary, "outcome": "dropped", "reason": f"the object fell (simulation truth); {saw}"[:512]}
    if summary.get("outcome") == "released" and truth.held_by != "receiver":
        reason = f"not released: the simulation truth has the object held by {truth.held_by}; {saw}"
        return {**summary, "outcome": "failed", "reason": reason[:512]}
    return summary


def simulated_robot(profile: Profile) -> bool:
    """Whether `profile`'s robot is simulated (the bridge's sim backend, or the fake Baxter),
    so that `sim/truth` comes from the stack itself; on real hardware nobody may claim it."""
    backend = profile.service_config("bridge").get("backend", "sim")
    return profile.service("fake_baxter") is not None or (profile.service("bridge") is not None and backend == "sim")
