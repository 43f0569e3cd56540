"""The episode's outcome from the simulation's truth (issue 17, item 6).

In simulation the bridge publishes where the object really is (`sim/truth`); never used for
control, it decides the summary's outcome when it says the object fell: whatever the bus
said (a release event, a grip state), a dropped object is a ``dropped`` episode. On hardware
there is no truth and the summary is the sequencer's.
"""

from __future__ import annotations

from typing import Any

from bus_schema.messages import SimTruth


def outcome_from_truth(summary: dict[str, Any], truth: SimTruth | None) -> dict[str, Any]:
    """`summary` (EpisodeSummary fields) with outcome ``dropped`` when `truth` (the newest
    `sim/truth`, or None) says the object fell; the sequencer's verdict stays in the reason."""
    if truth is None or not truth.dropped or summary.get("outcome") == "dropped":
        return summary
    saw = f"{summary.get('outcome')}: {summary.get('reason', '')}"
    reason = f"the object fell (simulation truth); the supervisor saw {saw}"
    return {**summary, "outcome": "dropped", "reason": reason[:512]}
