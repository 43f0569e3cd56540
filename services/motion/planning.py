"""Turns an accepted goal into a plan from a start joint state, and plans the brake of a stop.

- ``transfer``: a minimum-jerk Cartesian reach (`paths.CartesianReach`) from the current tool
  state, slowed next to the receiver's hand (`paths.zone_limited_duration_s`) and checked by
  a dry run of the live IK tracking (stretched ×1.5 up to `_STRETCH_ATTEMPTS` times when the
  IK cannot keep up).
- ``pick``, ``retract``, ``joint``: a Ruckig jerk-limited joint move to an IK (or given) joint
  target, stretched until its tool speed next to the receiver's hand is within the cap.
- a stop: the fastest Ruckig brake to rest within the stop limits.

Joint states are (q, dq, ddq): positions (n,) rad, velocities (n,) rad/s, accelerations (n,)
rad/s²; tool quantities are in the scene's `base` frame, m, m/s, m/s².
"""

from __future__ import annotations

import math

import numpy as np

from bus_schema.messages import MotionGoal
from services.motion.config import MotionConfig
from services.motion.errors import GoalRejected, TrajectoryError
from services.motion.goal_targets import goal_joint_target_rad, goal_position_m, goal_rotation
from services.motion.ik import ArmIk
from services.motion.paths import (
    CartesianReach,
    JointLimits,
    JointTrajectory,
    JointTrajectoryPlanner,
    QuinticPath,
    rest_to_rest_duration_s,
    zone_limited_duration_s,
)

#: Extra ticks allowed after a Cartesian path's end for the IK to converge on the goal pose.
CONVERGE_TICKS = 50


def ends_close_enough(position_error_m: float, orientation_error_rad: float, config: MotionConfig) -> bool:
    """Whether a transfer reach that did not converge within `CONVERGE_TICKS` ticks of its
    path's end is accepted where the IK ended: position error (m) within
    `transfer_end_tolerance_m`, orientation error (rad) within `orientation_tolerance_rad`."""
    return (position_error_m <= config.transfer_end_tolerance_m
            and orientation_error_rad <= config.orientation_tolerance_rad)


#: Times a Cartesian goal's duration is stretched (×1.5 each) when the IK cannot keep up.
_STRETCH_ATTEMPTS = 3
#: Times a joint move is stretched to meet the receiver-zone speed cap before giving up.
_ZONE_STRETCH_ATTEMPTS = 6


class RestFirst(Exception):
    """The goal cannot start from the current motion (the tool is faster than the cap next to
    the receiver's hand): brake to rest within the stop limits first, then plan it."""


class GoalPlanner:
    """Plans goals and brakes for one arm.

    Args:
        config: service configuration (limits, speeds, tolerances, control period).
        ik: the PlaCo IK of the arm (tool poses, IK solves, the tracking dry run).
    """

    def __init__(self, config: MotionConfig, ik: ArmIk) -> None:
        self.config = config
        self.ik = ik
        n = len(ik.joint_names)
        self.ruckig = JointTrajectoryPlanner(n)
        velocity = ik.velocity_limit_rad_s
        self.move_limits = JointLimits(
            ik.lower_rad, ik.upper_rad, velocity,
            np.full(n, config.joint_acceleration_rad_s2), np.full(n, config.joint_jerk_rad_s3),
        )
        self.stop_limits = JointLimits(
            ik.lower_rad, ik.upper_rad, velocity,
            np.full(n, config.stop_acceleration_rad_s2), np.full(n, config.stop_jerk_rad_s3),
        )

    def brake(self, q0: np.ndarray, dq0: np.ndarray, ddq0: np.ndarray) -> JointTrajectory:
        """The fastest brake from (q0, dq0, ddq0) to rest within the stop limits.

        Raises:
            TrajectoryError: Ruckig failed.
        """
        return self.ruckig.stop(q0, dq0, ddq0, self.stop_limits)

    # ------------------------------------------------------------------ tool state

    def tool_state(self, q: np.ndarray, dq: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tool position, rotation and (finite-difference) velocity for joint state (q, dq)."""
        eps = 1e-4
        p_ahead, _ = self.ik.tool_pose(q + dq * eps)
        p, rotation = self.ik.tool_pose(q)
        return p, rotation, (p_ahead - p) / eps

    def tool_acceleration(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """Tool acceleration (finite differences over a short step of the joint motion)."""
        h = 1e-3
        _, _, v_next = self.tool_state(q + dq * h + 0.5 * ddq * h * h, dq + ddq * h)
        _, _, v_now = self.tool_state(q, dq)
        return (v_next - v_now) / h

    # ------------------------------------------------------------------ transfer

    def transfer(self, goal: MotionGoal, q0: np.ndarray, dq0: np.ndarray, ddq0: np.ndarray) -> CartesianReach:
        """The Cartesian reach of a ``transfer`` goal from the joint state (q0, dq0, ddq0).

        Raises:
            GoalRejected: malformed goal, or the IK cannot follow the straight path.
            RestFirst: the tool already moves faster than the receiver-zone cap allows.
            TrajectoryError: no path from rest meets the receiver-zone cap.
        """
        cfg = self.config
        target = goal_position_m(goal, cfg)
        rotation = goal_rotation(goal)
        p0, r0, v0 = self.tool_state(q0, dq0)
        moving = bool(np.linalg.norm(v0) > 1e-6)
        a0 = self.tool_acceleration(q0, dq0, ddq0) if moving else np.zeros(3)
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
                raise RestFirst(str(exc)) from None
        last_error = ""
        for _ in range(_STRETCH_ATTEMPTS):
            reach = CartesianReach(p0, target, r0, rotation, duration, v0 if moving else None,
                                   a0 if moving else None)
            last_error = self.rollout_error(reach, q0)
            if not last_error:
                return reach
            duration *= 1.5
        raise GoalRejected(f"transfer goal unreachable along a straight path: {last_error}")

    def rollout_error(self, reach: CartesianReach, q0: np.ndarray) -> str:
        """Track `reach` tick by tick as the live loop will; '' if it stays on the path and converges."""
        cfg = self.config
        dt = cfg.period_s
        q = q0.copy()
        ticks = int(math.ceil(reach.duration_s / dt))
        for k in range(1, ticks + CONVERGE_TICKS + 1):
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
        if ends_close_enough(result.position_error_m, result.orientation_error_rad, cfg):
            return ""
        return (
            f"IK ends {result.position_error_m * 1000:.1f} mm / "
            f"{math.degrees(result.orientation_error_rad):.2f} deg from the goal pose "
            f"(accepted within {cfg.transfer_end_tolerance_m * 1000:.0f} mm and "
            f"{math.degrees(cfg.orientation_tolerance_rad):.1f} deg)"
        )

    # ------------------------------------------------------------------ joint moves

    def joint_move(self, goal: MotionGoal, q0: np.ndarray, dq0: np.ndarray, ddq0: np.ndarray) -> JointTrajectory:
        """The Ruckig move of a ``pick``, ``retract`` or ``joint`` goal from (q0, dq0, ddq0).

        The target: the goal's `joint_target_rad`, else the IK solution for its
        `position_base_m`, else (a retract) the arm's home.

        Raises:
            GoalRejected: malformed goal, or the move cannot meet the receiver-zone cap.
            IkError: no IK solution for the goal's position.
            TrajectoryError: Ruckig failed.
        """
        q_target = goal_joint_target_rad(goal, self.ik.lower_rad, self.ik.upper_rad, self.ik.joint_names)
        if q_target is None:
            if goal.kind == "joint":
                raise GoalRejected(f"a joint goal needs joint_target_rad ({len(self.ik.joint_names)} values)")
            if goal.position_base_m is not None:
                position = goal_position_m(goal, self.config)
                q_target = self.ik.solve(position, goal_rotation(goal), q0).q_rad
            elif goal.kind == "retract":
                q_target = np.array(self.ik.description.home_rad)
            else:
                raise GoalRejected("a pick goal needs position_base_m or joint_target_rad")
        trajectory = self.ruckig.move(q0, dq0, ddq0, q_target, self.move_limits, goal.duration_s)
        if goal.receiver_hand_position_m is not None:
            trajectory = self._zone_limit_joint_move(
                trajectory, q0, dq0, ddq0, q_target, np.array(goal.receiver_hand_position_m)
            )
        return trajectory

    def _zone_limit_joint_move(self, trajectory: JointTrajectory, q0: np.ndarray, dq0: np.ndarray,
                               ddq0: np.ndarray, q_target: np.ndarray, hand_m: np.ndarray) -> JointTrajectory:
        """Stretch a joint move until its tool speed near the receiver's hand is within the cap."""
        cfg = self.config
        for _ in range(_ZONE_STRETCH_ATTEMPTS):
            times = np.linspace(0.0, trajectory.duration_s, 101)
            speeds, near = [], []
            for t in times:
                q, dq, _ = trajectory.state_at(float(t))
                p, _, v = self.tool_state(q, dq)
                speeds.append(float(np.linalg.norm(v)))
                near.append(float(np.linalg.norm(p - hand_m)) < cfg.receiver_zone_radius_m)
            peak = max((s for s, n in zip(speeds, near) if n), default=0.0)
            if peak <= cfg.receiver_zone_speed_m_s:
                return trajectory
            stretched = trajectory.duration_s * peak / cfg.receiver_zone_speed_m_s * 1.05
            trajectory = self.ruckig.move(q0, dq0, ddq0, q_target, self.move_limits, stretched)
        raise GoalRejected("cannot slow the joint move to the receiver-zone speed cap")
