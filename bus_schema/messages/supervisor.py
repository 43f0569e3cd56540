"""The handover sequencer's state and episode summaries, and every service's heartbeat."""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.messages.perception import Posture
from bus_schema.types import U63, DurationS, ForceN, NonNegForceN, Text, Vec3M

SupervisorPhase = Literal[
    "idle",
    "locate",
    "pick",
    "plan",
    "reach",
    "transfer",
    "released",
    "retract",
    "done",
    "hold",
    "failed",
    "protective_stop",
]


#: The phases in which no episode runs: before the first, between two, after the last, or
#: latched after a protective stop. Readers that act only during an episode test against these
#: (the planner rests; the bridge stops the arm when the supervisor dies outside them).
PHASES_OUTSIDE_EPISODE: frozenset[str] = frozenset({"idle", "done", "failed", "protective_stop"})

#: A reader that acts on the supervisor's phase (the tracker, the planner) takes a
#: `SupervisorState` received longer ago than this as no word at all, s: the supervisor sends
#: one at least every 50 ms, so an older one means it is silent or gone.
SUPERVISOR_STATE_FRESH_S = 1.0

GripRequest = Literal["open", "carry", "transfer"]


class SupervisorState(Message, frozen=True, kw_only=True):
    """Handover sequencer state (10–100 Hz and on every change).

    Attributes:
        phase: current phase of the handover.
        episode_id: episode counter.
        reason: why the phase was entered (events, failures, the service that was lost).
        elapsed_s: time in the current phase, s.
        grip_request: what the gripper service should do: ``open`` (no object: fingers
            open), ``carry`` (hold the object firmly: pick and carry, or after a failed
            transfer), ``transfer`` (run the fail-safe release controller). The default keeps
            a gripper that hears no supervisor running its controller.
    """

    phase: SupervisorPhase
    episode_id: U63 = 0
    reason: Text = ""
    elapsed_s: DurationS = 0.0
    grip_request: GripRequest = "transfer"


EpisodeOutcome = Literal["released", "timeout", "aborted", "failed", "protective_stop", "dropped"]


class EpisodeSummary(Message, frozen=True, kw_only=True):
    """One handover episode, published by the supervisor when it ends.

    Attributes:
        episode_id: the episode.
        outcome: ``released`` (the gripper let go to the receiver), ``timeout`` (the
            receiver never took the object; retracted with it), ``aborted`` (receiver lost,
            retracted), ``failed`` (a step failed; see `reason`), ``protective_stop`` (a service
            was lost or went silent; the arm was stopped), ``dropped`` (in simulation: the
            simulation's truth says the object fell, whatever the other messages said).
        reason: one line on why it ended that way (names the service for a fault).
        transfer_point_base_m: the transfer point the reach went to (`base`, m).
        receiver_posture: posture the plan used.
        phase_durations_s: seconds spent in each phase, by phase name.
        peak_grip_force_n: largest grip command during the transfer, N.
        force_overshoot_n: peak grip command during the transfer minus the command when the
            transfer started (the thesis's overshoot), N.
        release_to_stop_s: release event → arm at rest (joint speeds zero), s (0 if no
            release).
        replans: new reach goals sent because the target moved.
        faults: services lost or silent during the episode (``name: what``).
    """

    episode_id: U63
    outcome: EpisodeOutcome
    reason: Text = ""
    transfer_point_base_m: Vec3M | None = None
    receiver_posture: Posture = "unknown"
    phase_durations_s: Annotated[dict[Annotated[str, Meta(max_length=32)], DurationS], Meta(max_length=16)] = {}
    peak_grip_force_n: NonNegForceN = 0.0
    force_overshoot_n: ForceN = 0.0
    release_to_stop_s: DurationS = 0.0
    replans: Annotated[int, Meta(ge=0, le=1000)] = 0
    faults: Annotated[list[Text], Meta(max_length=32)] = []


class Heartbeat(Message, frozen=True, kw_only=True):
    """A service's main loop is running (10 Hz from every service on one host, 20 Hz across
    hosts; the header's `source` names the service). A frozen process stops beating; its liveliness token stays up until
    the link lease expires, so the supervisor watches both.

    Attributes:
        uptime_s: seconds since the service connected.
        beats: heartbeats sent so far.
        pid: the sender's process id (0: not given). On one host the supervisor reads that
            process's scheduler figures to tell a starved process from a frozen one; it only
            ever delays a "silent" verdict, bounded (`services.runtime.sched`).
    """

    uptime_s: DurationS = 0.0
    beats: U63 = 0
    pid: Annotated[int, Meta(ge=0, le=4_194_304)] = 0
