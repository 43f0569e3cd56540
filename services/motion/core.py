"""The motion service's state machine (pure: no I/O, time is an input).

`MotionController.step(now_s, measured_q_rad, goals, stops)` runs once per control tick
(100 Hz). It returns the joint command to send (or None) and the status.

States (the `MotionStatus.state` on the bus):
- ``idle``: no goal yet; no command is sent (the bridge holds the arm).
- ``moving``: a goal runs. ``transfer`` is a straight minimum-jerk Cartesian reach tracked by
  one PlaCo IK step per tick; ``pick``, ``retract`` and ``joint`` are Ruckig jerk-limited joint
  moves to an IK (or given) joint target.
- ``reached``: the planned motion ended and the measured joints are within
  `reach_joint_tolerance_rad` of the final command.
- ``stopped``: a `MotionStop` arrived. A Ruckig stop brings the commanded joints to rest with
  the stop limits; the rest of the goal is dropped. Only a new goal moves the arm again.
- ``failed``: the goal was refused (malformed, outside the workspace, unreachable, no joint
  state) or failed while running (IK lost the path, the arm did not settle). A goal that
  fails while the arm moves also brings it to rest with a Ruckig stop.

Once a first command has been sent, a command is sent every tick: the moving target, then the
held final (or stopped) position, so the bridge's 200 ms command time-out never fires while this
service is alive.

Goals and stops that arrive in the same tick: goals are applied first, then stops, so a stop
always wins. Copies of a goal, and goals sent before a stop, are ignored (`goal_filter`).

The controller composes one part per job: `goal_filter` (which goals to act on),
`planning` (goal checks via `goal_targets`, Ruckig moves and brakes, Cartesian reaches),
`tracking` (the live IK stepping of a reach), `start_states` (where a goal or a brake
starts), `commanded` (the commanded joint state and tool speed) and `status` (what is
reported).
"""

from __future__ import annotations

import logging
from enum import Enum
from typing import Sequence

import numpy as np

from bus_schema.messages import MotionGoal, MotionStop
from services.motion.commanded import CommandedState
from services.motion.config import MotionConfig
from services.motion.errors import GoalRejected, IkError, TrajectoryError
from services.motion.goal_filter import GoalFilter
from services.motion.ik import ArmIk
from services.motion.joint_state import ArmMeasurement
from services.motion.paths import JointTrajectory
from services.motion.planning import GoalPlanner, RestFirst
from services.motion.start_states import brake_start, goal_start
from services.motion.status import Status, StatusBoard, TickOutput
from services.motion.tracking import CartesianTracker

log = logging.getLogger(__name__)


class _Mode(Enum):
    IDLE = "idle"
    CARTESIAN = "cartesian"
    JOINT = "joint"
    STOPPING = "stopping"
    HOLD = "hold"


class MotionController:
    """Goal / stop / status state machine of the motion service (see the module docstring).

    Args:
        config: service configuration.
        ik: the PlaCo IK (one per controller; loading the arm takes ~1.5 s).
    """

    def __init__(self, config: MotionConfig, ik: ArmIk | None = None) -> None:
        self.config = config
        self.ik = ik or ArmIk(config)
        self.planner = GoalPlanner(config, self.ik)
        self.goals = GoalFilter()
        self.commanded = CommandedState(self.ik)
        self._board = StatusBoard()
        self._mode = _Mode.IDLE
        self._deferred_goal: MotionGoal | None = None
        self._goal_id = ""
        self._t0_s = 0.0  # start of the running joint move or brake, monotonic s
        self._last_now_s: float | None = None
        self._measured: ArmMeasurement | None = None
        # Active plans.
        self._tracker: CartesianTracker | None = None
        self._joint_traj: JointTrajectory | None = None
        self._end_s = 0.0  # planned end of the running goal, monotonic s
        self._duration_s = 0.0

    # ------------------------------------------------------------------ public

    @property
    def status(self) -> Status:
        """Current status."""
        return self._board.status

    @property
    def at_rest(self) -> bool:
        """Nothing changes until a goal or a stop arrives: idle or holding still, no goal
        waiting for the arm to rest, no move left to judge settled (the node then ticks only
        to repeat the hold command, `services.runtime.repeat`)."""
        return (self._mode in (_Mode.IDLE, _Mode.HOLD) and self._deferred_goal is None
                and self.status.state != "moving")

    @property
    def commanded_q_rad(self) -> np.ndarray | None:
        """Last commanded joint positions (n,), rad, or None before the first command."""
        q = self.commanded.q_rad
        return None if q is None else q.copy()

    @property
    def planned_duration_s(self) -> float:
        """Planned duration of the running (or last) goal, s."""
        return self._duration_s

    def note_measurement(self, measured: ArmMeasurement) -> None:
        """Keep `measured` as the newest joint state (its age counts from `measured.at_s`)."""
        self._measured = measured

    def step(
        self,
        now_s: float,
        measured_q_rad: np.ndarray | None = None,
        goals: Sequence[MotionGoal] = (),
        stops: Sequence[MotionStop] = (),
        measured_dq_rad_s: np.ndarray | None = None,
        measured_at_s: float | None = None,
    ) -> TickOutput:
        """Advance one tick.

        Args:
            now_s: local monotonic time, s.
            measured_q_rad: newest measured right-arm joints (n,), rad, if one arrived since
                the last tick (else None: the previous measurement is kept with its age; the
                node gives it with `note_measurement` instead).
            goals: goals received since the last tick, oldest first.
            stops: stops received since the last tick.
            measured_dq_rad_s: measured joint velocities (n,), rad/s, with `measured_q_rad`.
            measured_at_s: local receive time of that measurement (default `now_s`).
        """
        self._board.begin_tick()
        if measured_q_rad is not None:
            self.note_measurement(ArmMeasurement(
                np.asarray(measured_q_rad, dtype=float),
                None if measured_dq_rad_s is None else np.asarray(measured_dq_rad_s, dtype=float),
                now_s if measured_at_s is None else measured_at_s,
            ))
        for stop in stops:  # first: a goal sent before a stop of this tick is not even planned
            self.goals.stop_seen(stop.source, stop.stamp_ns)
        for goal in goals:
            # Each goal once, never one sent before a stop (`goal_filter`): copies of a goal
            # and late arrivals must not move the arm again.
            why = self.goals.reason_to_ignore(goal.source, goal.goal_id, goal.seq, goal.stamp_ns)
            if why is None:
                self._accept_goal(goal, now_s)
            elif why != "a copy of the goal in progress":
                log.info("goal '%s' ignored: %s", goal.goal_id, why)
        if stops:
            self._apply_stop(stops[-1], now_s)
        self._advance(now_s)
        self._last_now_s = now_s
        self._board.set_tool_speed(self.commanded.reported_tool_speed_m_s)
        return self._output()

    def _output(self) -> TickOutput:
        commanded = self.commanded
        q = commanded.q_rad
        return TickOutput(
            command_q_rad=commanded.sent_q_rad(self.config.servo_lag_s),
            planned_q_rad=None if q is None else q.copy(),
            command_dq_rad_s=None if q is None else commanded.dq_rad_s.copy(),
            goal_id=self._goal_id,
            status=self._board.status,
            status_changed=self._board.changed,
        )

    def _set_status(self, state: str, reason: str = "", progress: float | None = None) -> None:
        if self._board.set(state, self._goal_id, self.commanded.reported_tool_speed_m_s, reason, progress):
            log.info("goal %r: %s %s", self._goal_id, state, reason)

    # ------------------------------------------------------------------ goals

    def _plan(self, goal: MotionGoal, now_s: float) -> None:
        """Plan `goal` from where the arm is (or is commanded) now; the plan becomes the
        running one only when planning succeeds."""
        moving = self._mode in (_Mode.CARTESIAN, _Mode.JOINT, _Mode.STOPPING)
        q0, dq0, ddq0 = goal_start(moving, self.config.joint_state_timeout_s, self.ik, self.commanded,
                                   self._measured, now_s)
        if goal.kind == "transfer":
            reach = self.planner.transfer(goal, q0, dq0, ddq0)
            self._tracker = CartesianTracker(self.config, self.ik, reach, q0)
            self._joint_traj = None
            self._duration_s = reach.duration_s
            self._mode = _Mode.CARTESIAN
        else:
            trajectory = self.planner.joint_move(goal, q0, dq0, ddq0)
            self._joint_traj = trajectory
            self._tracker = None
            self._duration_s = trajectory.duration_s
            self._mode = _Mode.JOINT

    def _accept_goal(self, goal: MotionGoal, now_s: float) -> None:
        stop_first = self._mode in (_Mode.CARTESIAN, _Mode.JOINT)
        self._goal_id = goal.goal_id
        self._deferred_goal = None  # a newer goal replaces one waiting for the arm to rest
        try:
            self._plan(goal, now_s)
        except RestFirst:
            # Brake within the stop limits (the Ruckig stop), then plan this goal from rest,
            # where a slow enough path next to the hand always exists.
            self._brake(now_s)
            self._set_status("moving", "slowing down next to the receiver's hand before the new reach",
                             progress=0.0)
            if self._mode is _Mode.STOPPING:
                self._deferred_goal = goal
            else:  # already at rest (or the stop could not be planned: holding): plan it now
                self._accept_goal(goal, now_s)
            return
        except (GoalRejected, IkError, TrajectoryError) as exc:
            self._fail(str(exc), now_s, stop_motion=stop_first)
            return
        self._t0_s = now_s
        self._end_s = now_s + self._duration_s
        self._set_status("moving", "", progress=0.0)

    # ------------------------------------------------------------------ stop / fail

    def _begin_stop(self, now_s: float) -> None:
        """Bring the arm to rest with a Ruckig stop (or hold if nothing moves); the brake
        starts where `start_states.brake_start` says."""
        commanded = self.commanded
        if commanded.q_rad is None:
            self._mode = _Mode.IDLE
            return
        q0, dq0, ddq0 = brake_start(self.config.servo_lag_s, self.ik, commanded, self._measured, now_s)
        if not np.any(np.abs(dq0) > 1e-9) and not commanded.is_moving():
            self._mode = _Mode.HOLD
            return
        try:
            self._joint_traj = self.planner.brake(q0, dq0, ddq0)
        except TrajectoryError as exc:
            log.error("Ruckig stop failed (%s); holding the measured position", exc)
            commanded.hold_at(q0)
            self._mode = _Mode.HOLD
            return
        self._tracker = None
        self._mode = _Mode.STOPPING

    def _brake(self, now_s: float) -> None:
        """Begin a stop whose first command is already one period into the braking."""
        self._begin_stop(now_s)
        self._t0_s = now_s - self.config.period_s

    def _apply_stop(self, stop: MotionStop, now_s: float) -> None:
        self._deferred_goal = None  # a stop cancels a goal waiting for the arm to rest
        if self._mode in (_Mode.CARTESIAN, _Mode.JOINT):
            self._brake(now_s)
        kind = "protective stop" if stop.protective else "stop"
        self._set_status("stopped", f"{kind}: {stop.reason}" if stop.reason else kind)

    def _fail(self, reason: str, now_s: float, stop_motion: bool) -> None:
        if stop_motion:
            self._brake(now_s)
        elif self._mode in (_Mode.CARTESIAN, _Mode.JOINT):
            self._mode = _Mode.HOLD
        self._set_status("failed", reason, progress=0.0)

    # ------------------------------------------------------------------ ticking

    def _advance(self, now_s: float) -> None:
        cfg = self.config
        if self._last_now_s is None:
            dt = cfg.period_s
        else:
            dt = min(max(now_s - self._last_now_s, 0.5 * cfg.period_s), 2.0 * cfg.period_s)
        elapsed = now_s - self._t0_s
        if self._mode is _Mode.CARTESIAN:
            self._advance_cartesian(now_s, dt)
        elif self._mode is _Mode.JOINT:
            assert self._joint_traj is not None  # set with the JOINT mode
            q, dq, ddq = self._joint_traj.state_at(elapsed)
            self.commanded.record(q, dt, dq, ddq)
            if elapsed >= self._duration_s:
                self._check_settled(now_s)
            else:
                self._set_status("moving", progress=elapsed / self._duration_s)
        elif self._mode is _Mode.STOPPING:
            self._advance_stopping(now_s, elapsed, dt)
        elif self._mode is _Mode.HOLD and self.commanded.q_rad is not None:
            self.commanded.record(self.commanded.q_rad, dt, np.zeros_like(self.commanded.q_rad),
                                 np.zeros_like(self.commanded.q_rad))
            if self.status.state == "moving":
                self._check_settled(now_s)

    def _advance_cartesian(self, now_s: float, dt: float) -> None:
        tracker = self._tracker
        assert tracker is not None  # set with the CARTESIAN mode
        tracker.advance_time(dt)
        # The planned end moves with the pauses of the path time (the settle time-out counts from it).
        self._end_s = max(self._end_s, now_s + tracker.remaining_s)
        step = tracker.step(self.commanded.q_rad, dt)
        if step.q_rad is not None:
            self.commanded.record(step.q_rad, dt)
        if step.failure:
            self._fail(step.failure, now_s, stop_motion=True)
        elif step.on_path:
            self._set_status("moving", progress=step.progress)
        elif step.converged:
            self.commanded.zero_derivatives()
            self._mode = _Mode.HOLD
            self._check_settled(now_s)

    def _advance_stopping(self, now_s: float, elapsed: float, dt: float) -> None:
        trajectory = self._joint_traj
        assert trajectory is not None  # set with the STOPPING mode
        q, dq, ddq = trajectory.state_at(elapsed)
        self.commanded.record(q, dt, dq, ddq)
        if elapsed < trajectory.duration_s:
            return
        self.commanded.zero_derivatives()
        self.commanded.tool_speed_m_s = 0.0
        self._mode = _Mode.HOLD
        if self._deferred_goal is not None:  # at rest: now plan the goal that waited
            goal, self._deferred_goal = self._deferred_goal, None
            self._accept_goal(goal, now_s)

    def _check_settled(self, now_s: float) -> None:
        """Declare `reached` once the measured joints match the final command."""
        cfg = self.config
        self._mode = _Mode.HOLD if self._mode is _Mode.JOINT else self._mode
        measured, q_commanded = self._measured, self.commanded.q_rad
        error = float("inf")
        if measured is not None and q_commanded is not None:
            error = float(np.max(np.abs(measured.q_rad - q_commanded)))
            if error <= cfg.reach_joint_tolerance_rad:
                self.commanded.tool_speed_m_s = 0.0
                self._set_status("reached", progress=1.0)
                return
        if now_s > self._end_s + cfg.settle_timeout_s:
            self._set_status(
                "failed",
                f"arm did not settle within {cfg.settle_timeout_s:.1f} s of the planned end "
                f"(largest joint error {error:.3f} rad); check the bridge",
            )
        else:
            self._set_status("moving", progress=1.0)
