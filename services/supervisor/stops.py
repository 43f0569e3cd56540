"""The stop rules: the release interrupt, the receiver-lost hold and the protective stop
(pure, no I/O, no clock).

- **Release interrupt**: once the gripper released the object (its release event, or its
  state saying released in case the event was lost) during the reach, the transfer or a
  hold, all arm motion stops at once: a `motion/stop` (the bridge brakes on it too).
- **Protective stop**: a critical service lost or silent stops the arm for good; the
  episode ends with the service named.
- A stop is never let go of: it is sent again every `stop_repeat_s` until the motion service
  reports stopped and the arm is at rest, then every `STOP_KEEPALIVE_S`; none is sent in the
  `STOP_SETTLE_S` before a due goal, and a goal leaves only `STOP_SETTLE_S` after the last
  stop, so a keep-alive never cancels the retract or a re-planned reach.

Times are the local monotonic clock (s).
"""

from __future__ import annotations

import math
from typing import Any

from bus_schema.messages import PHASES_OUTSIDE_EPISODE, JointState, MotionStatus
from services.supervisor.config import SupervisorConfig
from services.supervisor.episode import Episode

#: Once a stop is confirmed, it is still repeated this often (s): a stop is never let go of.
STOP_KEEPALIVE_S = 0.5
#: A new goal leaves at least this long after the last stop (s): the motion service and the
#: bridge apply a stop that reaches them together with (or just after) a goal to that goal,
#: so a keep-alive stop sent right before the retract or a re-planned reach would cancel it.
STOP_SETTLE_S = 0.1
#: Phases in which a release is the release interrupt (the object is at the receiver).
RELEASABLE_PHASES = ("reach", "transfer", "hold")
#: Phases that hold the arm stopped: their stop is sent again at every tick it is due.
STOPPED_PHASES = ("released", "protective_stop", "hold")
#: Motion states that confirm a stop (with the arm at rest).
MOTION_STOPPED_STATES = ("stopped", "idle", "failed")


def arm_at_rest(joints: JointState | None, rest_speed_rad_s: float) -> bool:
    """True when every joint of the newest `joints` is slower than `rest_speed_rad_s` (rad/s)."""
    return (joints is not None and bool(joints.velocity_rad_s)
            and max(abs(v) for v in joints.velocity_rad_s) < rest_speed_rad_s)


def release_applies(phase: str, episode: Episode | None) -> bool:
    """Whether a release now is the release interrupt: in a phase where the object can be
    released, the first release of the episode."""
    return episode is not None and phase in RELEASABLE_PHASES and episode.release_s is None


def protective_stop_applies(phase: str, episode: Episode | None, critical: bool) -> bool:
    """Whether a fault of a service (`critical` per the watch table) stops the arm for good
    in `phase`: not before the first episode (the start waits for the services), not again
    after a protective stop, never for a report-only service."""
    if not critical:
        return False
    if phase in PHASES_OUTSIDE_EPISODE and (episode is None or episode.summary_sent):
        if phase == "idle" and episode is None:
            return False
        if phase == "protective_stop":
            return False
    return True


def goal_imminent(phase: str, episode: Episode | None, phase_elapsed_s: float, now_s: float,
                  config: SupervisorConfig) -> bool:
    """A goal is due within `STOP_SETTLE_S` (the retract after the release dwell, or the
    abort after the receiver was lost too long); `phase_elapsed_s` is the time in `phase`, s."""
    if phase == "released" and episode is not None and episode.at_rest_since_s is not None:
        return now_s - episode.at_rest_since_s >= config.release_dwell_s - STOP_SETTLE_S
    if phase == "hold":
        return phase_elapsed_s >= config.human_return_s - STOP_SETTLE_S
    return False


class StopKeeper:
    """The stop in force and when it was last sent.

    Args:
        repeat_s: the stop is sent again this often until confirmed, s.
    """

    def __init__(self, repeat_s: float) -> None:
        self.repeat_s = repeat_s
        self.reason = ""
        self.protective = False
        self.confirmed = False
        self.last_sent_s = -math.inf

    def send(self, now_s: float, reason: str, protective: bool) -> dict[str, Any]:
        """A new stop at `now_s` (s): the `motion/stop` fields."""
        self.reason, self.protective = reason, protective
        self.confirmed = False
        self.last_sent_s = now_s
        return {"reason": reason, "protective": protective}

    def again(self, now_s: float, motion: MotionStatus | None, at_rest: bool,
              goal_imminent: bool) -> dict[str, Any] | None:
        """The stop sent again, when due at `now_s` (s), or None: every `repeat_s` until the
        motion service says stopped and the arm is at rest (a lost stop message is sent
        again), then every `STOP_KEEPALIVE_S`, except just before a due goal."""
        if not self.confirmed:
            self.confirmed = motion is not None and motion.state in MOTION_STOPPED_STATES and at_rest
        period = STOP_KEEPALIVE_S if self.confirmed else self.repeat_s
        if self.confirmed and goal_imminent:
            return None  # the arm is at rest and stopped: keep the next goal clear of a stop
        if now_s - self.last_sent_s < period:
            return None
        self.last_sent_s = now_s
        return {"reason": self.reason, "protective": self.protective}

    def settled(self, now_s: float) -> bool:
        """True once `STOP_SETTLE_S` has passed since the last stop: a goal may leave."""
        return now_s - self.last_sent_s >= STOP_SETTLE_S
