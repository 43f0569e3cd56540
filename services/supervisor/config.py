"""Typed configuration of the supervisor (`[services.supervisor.config]` in a deploy profile).

Example (deploy/sim.toml)::

    [services.supervisor.config]
    episodes = 1                 # handover episodes to run (0: keep going)
    transfer_timeout_s = 6.0     # the receiver never takes the object: retract with it
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from services.supervisor.errors import SupervisorConfigError

Seconds = Annotated[float, Meta(gt=0.0, le=600.0)]
Metres = Annotated[float, Meta(ge=0.0, le=2.0)]
Watch = Literal["critical", "report"]


class SupervisorConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Supervisor settings (times in s, distances in m, `base` frame).

    Attributes:
        rate_hz: sequencer rate (the thesis's handover controller runs at 100 Hz).
        episodes: episodes to run one after the other (0: until stopped).
        start_delay_s: wait this long after every watched service is alive before the first
            episode.
        start_timeout_s: give up (failed) if the watched services are not all alive by then.
        between_episodes_s: pause between two episodes.
        locate_timeout_s: time to find the human (tracked) and the object on the table.
        move_timeout_s: longest a pick/lift/retract move may take.
        grasp_timeout_s: after closing, the wrist must feel the object's weight within this.
        grasp_load_fraction: fraction of the object's weight the wrist must feel (F_sy).
        pregrasp_height_m: the approach comes from this far above the object.
        lift_height_m: the object is lifted this far before the reach.
        plan_timeout_s: time to get a transfer target from the planner.
        reach_timeout_s: longest a reach may take.
        transfer_timeout_s: the receiver must take the object within this after the reach
            (else retract with it: outcome ``timeout``).
        release_dwell_s: after the release the arm stays put this long (the hand clears).
        rest_speed_rad_s: joint speed below which the arm counts as at rest.
        stop_repeat_s: the stop message is repeated this often until the motion service
            reports ``stopped`` and the arm is at rest (a lost stop is sent again).
        goal_repeat_s: a motion goal is sent again this often until the motion service
            reports on it (a lost goal is sent again; the copies keep its ``goal_id``, which
            the motion service acts on once). Never after a stop.
        human_lost_s: the receiver counts as lost when not tracked (or no human state) for
            this long during the reach; the arm then holds.
        human_return_s: hold this long for the receiver to come back, then abort (retract).
        replan_threshold_m: a new transfer target farther than this from the current reach
            goal starts a new reach.
        max_replans: new reach goals allowed per episode.
        heartbeat_timeout_s: a watched service whose heartbeat (10 Hz on one host, 20 Hz
            across hosts) is older than this is silent; default (None): one beat period and
            0.15 s (`watchdog.default_heartbeat_timeout_s`: 0.25 s on one host, 0.2 s across
            hosts); refused below one period and 0.05 s. On one host a stopped service is
            silent sooner (about 0.13 s after its last beat: the kernel says it is stopped)
            and a starved one is excused (`services.runtime.sched`).
        report_heartbeat_timeout_s: the heartbeat age that makes a ``report``-only service
            silent (the recorder runs at a low CPU priority and may stall in long writes;
            nothing stops for it, so it is not judged by the 0.25 s of the critical ones).
        stream_timeout_s: a watched data stream (robot joint state, gripper state)
            older than this means its service is silent.
        watch: what a lost or silent service means: ``critical`` → protective stop,
            ``report`` → logged and reported in the episode summary. Services of the profile
            not listed are critical.
    """

    rate_hz: Annotated[float, Meta(ge=10.0, le=1000.0)] = 100.0
    episodes: Annotated[int, Meta(ge=0, le=100000)] = 1
    start_delay_s: Annotated[float, Meta(ge=0.0, le=600.0)] = 0.5
    start_timeout_s: Seconds = 60.0
    between_episodes_s: Annotated[float, Meta(ge=0.0, le=600.0)] = 1.0
    locate_timeout_s: Seconds = 20.0
    move_timeout_s: Seconds = 10.0
    grasp_timeout_s: Seconds = 2.0
    grasp_load_fraction: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.5
    pregrasp_height_m: Metres = 0.10
    lift_height_m: Metres = 0.15
    plan_timeout_s: Seconds = 10.0
    reach_timeout_s: Seconds = 15.0
    transfer_timeout_s: Seconds = 6.0
    release_dwell_s: Annotated[float, Meta(ge=0.0, le=60.0)] = 0.5
    rest_speed_rad_s: Annotated[float, Meta(gt=0.0, le=1.0)] = 0.01
    stop_repeat_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.05
    goal_repeat_s: Annotated[float, Meta(gt=0.0, le=5.0)] = 0.1
    human_lost_s: Seconds = 0.5
    human_return_s: Seconds = 3.0
    replan_threshold_m: Annotated[float, Meta(gt=0.0, le=2.0)] = 0.05
    max_replans: Annotated[int, Meta(ge=0, le=100)] = 3
    heartbeat_timeout_s: Annotated[float, Meta(gt=0.0, le=60.0)] | None = None
    report_heartbeat_timeout_s: Annotated[float, Meta(gt=0.0, le=60.0)] = 0.75
    stream_timeout_s: Annotated[float, Meta(gt=0.0, le=60.0)] = 0.2
    watch: dict[str, Watch] = msgspec.field(default_factory=lambda: {"recorder": "report"})

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz


def parse_config(table: dict[str, Any]) -> SupervisorConfig:
    """Validate `[services.supervisor.config]`.

    Raises:
        SupervisorConfigError: naming the bad key.
    """
    try:
        return msgspec.convert(table, SupervisorConfig)
    except msgspec.ValidationError as exc:
        raise SupervisorConfigError(f"invalid [services.supervisor.config]: {exc}") from None
