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
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from enum import Enum
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from bus_schema.messages import MotionGoal, MotionStop
from handover_model import baxter
from services.motion.config import MotionConfig
from services.motion.errors import GoalRejected, IkError, MotionError, TrajectoryError
from services.motion.goal_filter import GoalFilter
from services.motion.ik import UPRIGHT_ROTATION, ArmIk
from services.motion.paths import (
    CartesianReach,
    JointLimits,
    JointTrajectory,
    JointTrajectoryPlanner,
    QuinticPath,
    rest_to_rest_duration_s,
    zone_limited_duration_s,
)

log = logging.getLogger(__name__)

#: Extra ticks allowed after a Cartesian path's end for the IK to converge on the goal pose.
_CONVERGE_TICKS = 50
#: Times a Cartesian goal's duration is stretched (×1.5 each) when the IK cannot keep up.
_STRETCH_ATTEMPTS = 3
#: A joint state younger than this (s) is used as the start of a stop.
_FRESH_MEASUREMENT_S = 0.05


class _Mode(Enum):
    IDLE = "idle"
    CARTESIAN = "cartesian"
    JOINT = "joint"
    STOPPING = "stopping"
    HOLD = "hold"


@dataclass(frozen=True)
class Status:
    """What the service reports (fields of `MotionStatus`)."""

    state: str
    goal_id: str = ""
    reason: str = ""
    progress: float = 0.0
    tool_speed_m_s: float = 0.0


class _RestFirst(Exception):
    """The goal cannot start from the current motion (the tool is faster than the cap next to
    the receiver's hand): brake to rest within the stop limits first, then plan it."""


@dataclass(frozen=True)
class TickOutput:
    """Result of one control tick.

    Attributes:
        command_q_rad: joint positions to send (7,), rad, or None to send nothing: the planned
            joints plus the servo-lag lead `servo_lag_s × planned velocity` (clipped to limits).
        planned_q_rad: the planned joint positions (where the arm should be now), rad.
        command_dq_rad_s: feed-forward joint velocities (7,), rad/s (None with no command).
        goal_id: goal the command belongs to.
        status: current status.
        status_changed: the state, goal or reason changed during this tick.
    """

    command_q_rad: np.ndarray | None
    planned_q_rad: np.ndarray | None
    command_dq_rad_s: np.ndarray | None
    goal_id: str
    status: Status
    status_changed: bool


def arm_positions_from(names: Sequence[str], positions: Sequence[float]) -> np.ndarray:
    """Right-arm joint positions (7,) in `RIGHT_ARM_JOINTS` order from a named joint list.

    Raises:
        MotionError: a right-arm joint is missing or the lists differ in length.
    """
    if len(names) != len(positions):
        raise MotionError(
            f"joint state has {len(names)} names but {len(positions)} positions"
        )
    index = {n: i for i, n in enumerate(names)}
    missing = [n for n in baxter.RIGHT_ARM_JOINTS if n not in index]
    if missing:
        raise MotionError(f"joint state lacks right-arm joint(s) {missing}")
    return np.array([positions[index[n]] for n in baxter.RIGHT_ARM_JOINTS], dtype=float)


class MotionController:
    """Goal / stop / status state machine of the motion service (see the module docstring).

    Args:
        config: service configuration.
        ik: the PlaCo IK (one per controller; loading Baxter takes ~1.5 s).
    """

    def __init__(self, config: MotionConfig, ik: ArmIk | None = None) -> None:
        self.config = config
        self.ik = ik or ArmIk(config)
        self.planner = JointTrajectoryPlanner(7)
        n = 7
        velocity = self.ik.velocity_limit_rad_s
        self.move_limits = JointLimits(
            self.ik.lower_rad, self.ik.upper_rad, velocity,
            np.full(n, config.joint_acceleration_rad_s2), np.full(n, config.joint_jerk_rad_s3),
        )
        self.stop_limits = JointLimits(
            self.ik.lower_rad, self.ik.upper_rad, velocity,
            np.full(n, config.stop_acceleration_rad_s2), np.full(n, config.stop_jerk_rad_s3),
        )
        self._mode = _Mode.IDLE
        self.goals = GoalFilter()
        self._deferred_goal: MotionGoal | None = None
        self._status = Status("idle")
        self._goal_id = ""
        self._t0_s = 0.0
        self._last_now_s: float | None = None
        self._measured_q: np.ndarray | None = None
        self._measured_dq: np.ndarray | None = None
        self._measured_at_s = -math.inf
        # Commanded joint state (what was last sent) and its derivatives.
        self._q_cmd: np.ndarray | None = None
        self._dq_cmd = np.zeros(n)
        self._ddq_cmd = np.zeros(n)
        self._tool_cmd_m: np.ndarray | None = None
        self._tool_speed_m_s = 0.0
        self._tool_velocity_m_s = np.zeros(3)
        # Active plans.
        self._reach: CartesianReach | None = None
        self._reach_q0 = np.zeros(n)
        self._reach_end_tick = 0
        self._path_time_s, self._path_started = 0.0, False  # Cartesian path time, s
        self._ticks_after_end = 0
        self._joint_traj: JointTrajectory | None = None
        self._end_s = 0.0
        self._duration_s = 0.0
        self._changed = False

    # ------------------------------------------------------------------ public

    @property
    def status(self) -> Status:
        """Current status."""
        return self._status

    @property
    def at_rest(self) -> bool:
        """Nothing changes until a goal or a stop arrives: idle or holding still, no goal
        waiting for the arm to rest, no move left to judge settled (the node then ticks only
        to repeat the hold command, `services.runtime.repeat`)."""
        return (self._mode in (_Mode.IDLE, _Mode.HOLD) and self._deferred_goal is None
                and self._status.state != "moving")

    @property
    def commanded_q_rad(self) -> np.ndarray | None:
        """Last commanded joint positions (7,), rad, or None before the first command."""
        return None if self._q_cmd is None else self._q_cmd.copy()

    @property
    def planned_duration_s(self) -> float:
        """Planned duration of the running (or last) goal, s."""
        return self._duration_s

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
            measured_q_rad: newest measured right-arm joints (7,), rad, if one arrived since
                the last tick (else None: the previous measurement is kept with its age).
            goals: goals received since the last tick, oldest first.
            stops: stops received since the last tick.
            measured_dq_rad_s: measured joint velocities (7,), rad/s, with `measured_q_rad`.
            measured_at_s: local receive time of that measurement (default `now_s`).
        """
        self._changed = False
        if measured_q_rad is not None:
            self._measured_q = np.asarray(measured_q_rad, dtype=float)
            self._measured_dq = (
                None if measured_dq_rad_s is None else np.asarray(measured_dq_rad_s, dtype=float)
            )
            self._measured_at_s = now_s if measured_at_s is None else measured_at_s
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
        if self._status.tool_speed_m_s != self._tool_speed_m_s:
            st = self._status
            self._status = Status(st.state, st.goal_id, st.reason, st.progress,
                                  float(min(self._tool_speed_m_s, 1000.0)))
        sent = None
        if self._q_cmd is not None:
            lead = self.config.servo_lag_s * self._dq_cmd
            sent = np.clip(self._q_cmd + lead, self.ik.lower_rad, self.ik.upper_rad)
        return TickOutput(
            command_q_rad=sent,
            planned_q_rad=None if self._q_cmd is None else self._q_cmd.copy(),
            command_dq_rad_s=None if self._q_cmd is None else self._dq_cmd.copy(),
            goal_id=self._goal_id,
            status=self._status,
            status_changed=self._changed,
        )

    # ------------------------------------------------------------------ status

    def _set_status(self, state: str, reason: str = "", progress: float | None = None) -> None:
        old = self._status
        progress = old.progress if progress is None else progress
        self._status = Status(
            state=state,
            goal_id=self._goal_id,
            reason=reason[:512],
            progress=float(min(1.0, max(0.0, progress))),
            tool_speed_m_s=float(min(self._tool_speed_m_s, 1000.0)),
        )
        if (old.state, old.goal_id, old.reason) != (state, self._goal_id, self._status.reason):
            self._changed = True
            log.info("goal %r: %s %s", self._goal_id, state, reason)

    # ------------------------------------------------------------------ goals

    def _start_state(self, now_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where a new goal starts: the commanded state while moving, else the measured joints."""
        if self._mode in (_Mode.CARTESIAN, _Mode.JOINT, _Mode.STOPPING) and self._q_cmd is not None:
            return self._q_cmd.copy(), self._dq_cmd.copy(), self._ddq_cmd.copy()
        if self._measured_q is None or now_s - self._measured_at_s > self.config.joint_state_timeout_s:
            age = now_s - self._measured_at_s
            raise GoalRejected(
                "no fresh joint state from the bridge"
                + ("" if self._measured_q is None else f" (last one {age:.2f} s old)")
                + "; is handover-bridge running?"
            )
        return self.ik.clip_to_limits(self._measured_q.copy()), np.zeros(7), np.zeros(7)

    def _goal_rotation(self, goal: MotionGoal) -> np.ndarray:
        if goal.orientation_xyzw is None:
            return UPRIGHT_ROTATION
        quat = np.array(goal.orientation_xyzw, dtype=float)
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > 1e-3:
            raise GoalRejected(f"orientation_xyzw is not a unit quaternion (norm {norm:.4f})")
        return Rotation.from_quat(quat / norm).as_matrix()

    def _goal_position(self, goal: MotionGoal) -> np.ndarray:
        if goal.position_base_m is None:
            raise GoalRejected(f"a {goal.kind} goal needs position_base_m")
        p = np.array(goal.position_base_m, dtype=float)
        lo = np.array(self.config.workspace_min_m)
        hi = np.array(self.config.workspace_max_m)
        outside = [
            f"{axis}={p[i]:.3f} not in [{lo[i]:.2f}, {hi[i]:.2f}]"
            for i, axis in enumerate("xyz")
            if not lo[i] <= p[i] <= hi[i]
        ]
        if outside:
            raise GoalRejected("goal outside the workspace: " + ", ".join(outside) + " m (base frame)")
        return p

    def _joint_target(self, goal: MotionGoal) -> np.ndarray | None:
        if not goal.joint_target_rad:
            return None
        if len(goal.joint_target_rad) != 7:
            raise GoalRejected(
                f"joint_target_rad needs 7 values (right_s0..right_w2), got {len(goal.joint_target_rad)}"
            )
        q = np.array(goal.joint_target_rad, dtype=float)
        outside = (q < self.ik.lower_rad) | (q > self.ik.upper_rad)
        if outside.any():
            names = [baxter.RIGHT_ARM_JOINTS[i] for i in np.flatnonzero(outside)]
            raise GoalRejected(f"joint_target_rad outside the joint limits at {names}")
        return q

    def _accept_goal(self, goal: MotionGoal, now_s: float) -> None:
        stop_first = self._mode in (_Mode.CARTESIAN, _Mode.JOINT)
        self._goal_id = goal.goal_id
        self._deferred_goal = None  # a newer goal replaces one waiting for the arm to rest
        try:
            q0, dq0, ddq0 = self._start_state(now_s)
            if goal.kind == "transfer":
                self._plan_transfer(goal, q0, dq0, ddq0)
            else:
                self._plan_joint_move(goal, q0, dq0, ddq0)
        except _RestFirst:
            # Brake within the stop limits (the Ruckig stop), then plan this goal from rest,
            # where a slow enough path next to the hand always exists.
            self._begin_stop(now_s)
            self._t0_s = now_s - self.config.period_s
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
        self._path_time_s, self._path_started = 0.0, False
        self._end_s = now_s + self._duration_s
        self._ticks_after_end = 0
        self._set_status("moving", "", progress=0.0)

    def _tool_state(self, q: np.ndarray, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tool position, rotation and (finite-difference) velocity for joint state (q, dq)."""
        eps = 1e-4
        p_ahead, _ = self.ik.tool_pose(q + dq * eps)
        p, rotation = self.ik.tool_pose(q)
        return p, rotation, (p_ahead - p) / eps

    def _plan_transfer(self, goal: MotionGoal, q0, dq0, ddq0) -> None:
        cfg = self.config
        target = self._goal_position(goal)
        rotation = self._goal_rotation(goal)
        p0, r0, v0 = self._tool_state(q0, dq0)
        moving = bool(np.linalg.norm(v0) > 1e-6)
        a0 = self._tool_acceleration(q0, dq0, ddq0) if moving else np.zeros(3)
        distance = float(np.linalg.norm(target - p0))
        duration = rest_to_rest_duration_s(
            distance, goal.duration_s, goal.peak_speed_m_s, cfg.default_normalized_peak_speed_1_s,
            cfg.max_tool_speed_m_s, cfg.min_duration_s,
        )

        def make_path(d: float) -> QuinticPath:
            return QuinticPath(p0, target, d, v0 if moving else None, a0 if moving else None)

        if goal.receiver_hand_position_m is not None:
            hand = np.array(goal.receiver_hand_position_m)
            try:
                duration = zone_limited_duration_s(make_path, duration, hand, cfg.receiver_zone_radius_m,
                                                   cfg.receiver_zone_speed_m_s)
            except TrajectoryError as exc:
                if not moving:
                    raise
                # A new goal while the tool is already faster than the cap next to the hand (a
                # re-plan mid-reach): no path that starts at the current speed meets the cap.
                raise _RestFirst(str(exc)) from None
        last_error = ""
        for _ in range(_STRETCH_ATTEMPTS):
            reach = CartesianReach(p0, target, r0, rotation, duration, v0 if moving else None,
                                   a0 if moving else None)
            last_error = self._rollout_error(reach, q0)
            if not last_error:
                break
            duration *= 1.5
        else:
            raise GoalRejected(f"transfer goal unreachable along a straight path: {last_error}")
        self._reach = reach
        self._reach_q0 = q0.copy()
        self._joint_traj = None
        self._duration_s = duration
        self._mode = _Mode.CARTESIAN
        self._reach_end_tick = 0

    def _tool_acceleration(self, q, dq, ddq) -> np.ndarray:
        """Tool acceleration (finite differences over a short step of the joint motion)."""
        h = 1e-3
        _, _, v_next = self._tool_state(q + dq * h + 0.5 * ddq * h * h, dq + ddq * h)
        _, _, v_now = self._tool_state(q, dq)
        return (v_next - v_now) / h

    def _rollout_error(self, reach: CartesianReach, q0: np.ndarray) -> str:
        """Track `reach` tick by tick as the live loop will; '' if it stays on the path and converges."""
        cfg = self.config
        dt = cfg.period_s
        q = q0.copy()
        ticks = int(math.ceil(reach.duration_s / dt))
        for k in range(1, ticks + _CONVERGE_TICKS + 1):
            p, rot, _ = reach.pose_at(k * dt)
            result = self.ik.track_step(p, rot, q, dt)
            q = result.q_rad
            if k <= ticks and (
                result.position_error_m > cfg.tracking_tolerance_m
                or result.orientation_error_rad > cfg.tracking_tolerance_rad
            ):
                return (
                    f"IK falls {result.position_error_m * 1000:.0f} mm / "
                    f"{math.degrees(result.orientation_error_rad):.1f} deg behind the path at "
                    f"{k * dt:.2f} s of {reach.duration_s:.2f} s (joint limits or speed)"
                )
            if k >= ticks and (
                result.position_error_m <= cfg.position_tolerance_m
                and result.orientation_error_rad <= cfg.orientation_tolerance_rad
            ):
                return ""
        return (
            f"IK ends {result.position_error_m * 1000:.1f} mm / "
            f"{math.degrees(result.orientation_error_rad):.2f} deg from the goal pose"
        )

    def _plan_joint_move(self, goal: MotionGoal, q0, dq0, ddq0) -> None:
        q_target = self._joint_target(goal)
        if q_target is None:
            if goal.kind == "joint":
                raise GoalRejected("a joint goal needs joint_target_rad (7 values)")
            if goal.position_base_m is not None:
                position = self._goal_position(goal)
                q_target = self.ik.solve(position, self._goal_rotation(goal), q0).q_rad
            elif goal.kind == "retract":
                q_target = np.array(baxter.RIGHT_ARM_HOME_RAD)
            else:
                raise GoalRejected("a pick goal needs position_base_m or joint_target_rad")
        trajectory = self.planner.move(q0, dq0, ddq0, q_target, self.move_limits, goal.duration_s)
        if goal.receiver_hand_position_m is not None:
            trajectory = self._zone_limit_joint_move(
                trajectory, q0, dq0, ddq0, q_target, np.array(goal.receiver_hand_position_m)
            )
        self._joint_traj = trajectory
        self._reach = None
        self._duration_s = trajectory.duration_s
        self._mode = _Mode.JOINT

    def _zone_limit_joint_move(self, trajectory, q0, dq0, ddq0, q_target, hand_m) -> JointTrajectory:
        """Stretch a joint move until its tool speed near the receiver's hand is within the cap."""
        cfg = self.config
        for _ in range(6):
            times = np.linspace(0.0, trajectory.duration_s, 101)
            speeds, near = [], []
            for t in times:
                q, dq, _ = trajectory.state_at(float(t))
                p, _, v = self._tool_state(q, dq)
                speeds.append(float(np.linalg.norm(v)))
                near.append(float(np.linalg.norm(p - hand_m)) < cfg.receiver_zone_radius_m)
            peak = max((s for s, n in zip(speeds, near) if n), default=0.0)
            if peak <= cfg.receiver_zone_speed_m_s:
                return trajectory
            stretched = trajectory.duration_s * peak / cfg.receiver_zone_speed_m_s * 1.05
            trajectory = self.planner.move(q0, dq0, ddq0, q_target, self.move_limits, stretched)
        raise GoalRejected("cannot slow the joint move to the receiver-zone speed cap")

    # ------------------------------------------------------------------ stop / fail

    def _begin_stop(self, now_s: float) -> None:
        """Bring the arm to rest with a Ruckig stop (or hold if nothing moves).

        With a lagging servo (`servo_lag_s` > 0) the stop starts from the measured joint state
        when a fresh one (with velocities) is at hand, extrapolated to `now_s`: braking from the
        command would first let the arm run through that lag. With a servo that tracks its
        commands (velocity feed-forward, `servo_lag_s` = 0, the bridge's behaviour) it starts
        from the commanded state, which is where the arm is; a measurement is up to a tick old,
        and braking from it would make the arm creep back through the servo's lag.
        """
        if self._q_cmd is None:
            self._mode = _Mode.IDLE
            return
        measured_q, measured_dq = self._measured_q, self._measured_dq
        if (
            self.config.servo_lag_s > 0.0
            and measured_q is not None
            and measured_dq is not None
            and now_s - self._measured_at_s <= _FRESH_MEASUREMENT_S
        ):
            age = max(0.0, now_s - self._measured_at_s)
            q0 = self.ik.clip_to_limits(measured_q + measured_dq * age)
            dq0, ddq0 = measured_dq.copy(), np.zeros(7)
        else:
            q0, dq0, ddq0 = self._q_cmd, self._dq_cmd, self._ddq_cmd
        if not np.any(np.abs(dq0) > 1e-9) and not np.any(np.abs(self._dq_cmd) > 1e-9):
            self._mode = _Mode.HOLD
            return
        try:
            self._joint_traj = self.planner.stop(q0, dq0, ddq0, self.stop_limits)
        except TrajectoryError as exc:
            log.error("Ruckig stop failed (%s); holding the measured position", exc)
            self._q_cmd = q0.copy()
            self._dq_cmd[:] = 0.0
            self._ddq_cmd[:] = 0.0
            self._mode = _Mode.HOLD
            return
        self._reach = None
        self._mode = _Mode.STOPPING

    def _apply_stop(self, stop: MotionStop, now_s: float) -> None:
        self._deferred_goal = None  # a stop cancels a goal waiting for the arm to rest
        if self._mode in (_Mode.CARTESIAN, _Mode.JOINT):
            self._begin_stop(now_s)
            # The stop's first command is already one period into the braking.
            self._t0_s = now_s - self.config.period_s
        kind = "protective stop" if stop.protective else "stop"
        self._set_status("stopped", f"{kind}: {stop.reason}" if stop.reason else kind)

    def _fail(self, reason: str, now_s: float, stop_motion: bool) -> None:
        if stop_motion:
            self._begin_stop(now_s)
            self._t0_s = now_s - self.config.period_s
        elif self._mode in (_Mode.CARTESIAN, _Mode.JOINT):
            self._mode = _Mode.HOLD
        self._set_status("failed", reason, progress=0.0)

    # ------------------------------------------------------------------ ticking

    def _command(self, q: np.ndarray, dt: float, dq: np.ndarray | None = None,
                 ddq: np.ndarray | None = None) -> None:
        """Record a new command and its derivatives (finite differences when not given)."""
        previous_q = self._q_cmd
        previous_dq = self._dq_cmd
        if dq is None:
            dq = np.zeros(7) if previous_q is None else (q - previous_q) / dt
        if ddq is None:
            ddq = (dq - previous_dq) / dt
        self._q_cmd = q.copy()
        self._dq_cmd = np.asarray(dq, dtype=float).copy()
        self._ddq_cmd = np.asarray(ddq, dtype=float).copy()
        p, _ = self.ik.tool_pose(q)
        if self._tool_cmd_m is not None:
            self._tool_velocity_m_s = (p - self._tool_cmd_m) / dt
            self._tool_speed_m_s = float(np.linalg.norm(self._tool_velocity_m_s))
        self._tool_cmd_m = p

    def _advance(self, now_s: float) -> None:
        cfg = self.config
        if self._last_now_s is None:
            dt = cfg.period_s
        else:
            dt = min(max(now_s - self._last_now_s, 0.5 * cfg.period_s), 2.0 * cfg.period_s)
        elapsed = now_s - self._t0_s
        if self._mode is _Mode.CARTESIAN:
            # Path time advances by the (clamped) tick period, not the wall clock: a tick that
            # comes late (the process starved of CPU) pauses the path instead of making the
            # target jump further than one IK step can follow.
            if self._path_started:
                self._path_time_s += dt
            self._path_started = True
            # The planned end moves with the pauses (the settle time-out counts from it).
            self._end_s = max(self._end_s, now_s + max(0.0, self._duration_s - self._path_time_s))
            self._advance_cartesian(now_s, self._path_time_s, dt)
        elif self._mode is _Mode.JOINT:
            assert self._joint_traj is not None  # set with the JOINT mode
            q, dq, ddq = self._joint_traj.state_at(elapsed)
            self._command(q, dt, dq, ddq)
            if elapsed >= self._duration_s:
                self._check_settled(now_s)
            else:
                self._set_status("moving", progress=elapsed / self._duration_s)
        elif self._mode is _Mode.STOPPING:
            assert self._joint_traj is not None  # set with the STOPPING mode
            q, dq, ddq = self._joint_traj.state_at(elapsed)
            self._command(q, dt, dq, ddq)
            if elapsed >= self._joint_traj.duration_s:
                self._dq_cmd[:] = 0.0
                self._ddq_cmd[:] = 0.0
                self._tool_speed_m_s = 0.0
                self._mode = _Mode.HOLD
                if self._deferred_goal is not None:  # at rest: now plan the goal that waited
                    goal, self._deferred_goal = self._deferred_goal, None
                    self._accept_goal(goal, now_s)
        elif self._mode is _Mode.HOLD and self._q_cmd is not None:
            self._command(self._q_cmd, dt, np.zeros(7), np.zeros(7))
            if self._status.state == "moving":
                self._check_settled(now_s)

    def _advance_cartesian(self, now_s: float, elapsed: float, dt: float) -> None:
        cfg = self.config
        reach = self._reach
        assert reach is not None  # set with the CARTESIAN mode
        p, rotation, _ = reach.pose_at(elapsed)
        q_from = self._reach_q0 if elapsed <= 0.0 or self._q_cmd is None else self._q_cmd
        try:
            result = self.ik.track_step(p, rotation, q_from, dt)
        except IkError as exc:
            self._fail(f"IK failed while tracking the path: {exc}", now_s, stop_motion=True)
            return
        self._command(result.q_rad, dt)
        if elapsed < reach.duration_s:
            if (result.position_error_m > cfg.tracking_tolerance_m
                    or result.orientation_error_rad > cfg.tracking_tolerance_rad):
                self._fail(
                    f"IK fell {result.position_error_m * 1000:.0f} mm behind the path",
                    now_s, stop_motion=True,
                )
                return
            self._set_status("moving", progress=elapsed / reach.duration_s)
            return
        self._ticks_after_end += 1
        converged = (result.position_error_m <= cfg.position_tolerance_m
                     and result.orientation_error_rad <= cfg.orientation_tolerance_rad)
        if converged:
            self._dq_cmd[:] = 0.0
            self._ddq_cmd[:] = 0.0
            self._mode = _Mode.HOLD
            self._check_settled(now_s)
        elif self._ticks_after_end > _CONVERGE_TICKS:
            self._fail(
                f"IK ended {result.position_error_m * 1000:.1f} mm from the goal", now_s,
                stop_motion=True,
            )

    def _check_settled(self, now_s: float) -> None:
        """Declare `reached` once the measured joints match the final command."""
        cfg = self.config
        self._mode = _Mode.HOLD if self._mode is _Mode.JOINT else self._mode
        if self._measured_q is not None and self._q_cmd is not None:
            error = float(np.max(np.abs(self._measured_q - self._q_cmd)))
            if error <= cfg.reach_joint_tolerance_rad:
                self._tool_speed_m_s = 0.0
                self._set_status("reached", progress=1.0)
                return
        else:
            error = math.inf
        if now_s > self._end_s + cfg.settle_timeout_s:
            self._set_status(
                "failed",
                f"arm did not settle within {cfg.settle_timeout_s:.1f} s of the planned end "
                f"(largest joint error {error:.3f} rad); check the bridge",
            )
        else:
            self._set_status("moving", progress=1.0)
