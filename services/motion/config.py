"""Typed, validated configuration of the motion service.

Every value has an SI unit in its name. The defaults are the simulation's; a deploy profile
overrides any of them in `[services.motion.config]`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from handover_model.robots import RobotDescription
from services.motion.errors import MotionConfigError


@dataclass(frozen=True)
class MotionConfig:
    """Motion service settings.

    Attributes:
        rate_hz: control rate; one IK step and one joint command per tick.
        status_rate_hz: periodic status rate (status is also sent on every change).
        workspace_min_m, workspace_max_m: axis-aligned box (base frame) that Cartesian goals
            must lie in; anything outside is refused before IK is tried.
        position_tolerance_m, orientation_tolerance_rad: IK success tolerance on the tool
            frame (1 mm, 1°).
        transfer_end_tolerance_m: a transfer reach whose IK has not come within
            `position_tolerance_m` of the goal `CONVERGE_TICKS` ticks after the path's end is
            still accepted (held where the IK ended) when it ended this close, m. An arm with
            fewer than six joints (SO-ARM101) often cannot reach the full goal pose exactly;
            the transfer point itself moves by centimetres between two plans (the tracked
            hand's noise), so a few millimetres are no failure. The IK still aims at the goal.
        ik_max_iterations: iterations of the offline IK solve for a goal pose.
        ik_step_s: pseudo time step of the offline IK solve; with the velocity limits it
            bounds each iteration's joint step to `velocity limit × ik_step_s` (damping).
        ik_no_progress_iterations: the offline solve gives up when the error has not dropped
            by `ik_no_progress_ratio` over this many iterations.
        ik_no_progress_ratio: relative error decrease required over that window.
        ik_restarts: random start postures tried after the seed and the posture fail.
        ik_restart_seed: seed of those random start postures (repeatable answers).
        posture_weight: weight of the posture regularisation (toward `posture_rad`) relative to
            the tool pose tasks (weight 1).
        tracking_tolerance_m, tracking_tolerance_rad: largest tool error allowed while a
            Cartesian path is tracked tick by tick before the goal fails.
        velocity_scale: fraction of the URDF joint velocity limits used for planning.
        joint_acceleration_rad_s2, joint_jerk_rad_s3: Ruckig limits for pick/retract/joint
            moves (the URDF has none).
        stop_acceleration_rad_s2, stop_jerk_rad_s3: Ruckig limits for a stop (harder than for
            moves so that the arm halts within 50 ms from typical speeds).
        default_normalized_peak_speed_1_s: peak tool speed divided by path length when a goal
            gives neither duration nor peak speed (thesis §2.4.2: V_max 0.5–2.7 1/s).
        max_tool_speed_m_s: cap on the peak tool speed of any Cartesian path.
        min_duration_s: shortest Cartesian path duration.
        receiver_zone_radius_m, receiver_zone_speed_m_s: within this distance of the receiver's
            hand the tool speed stays at or below this speed (DESIGN §8).
        reach_joint_tolerance_rad: the goal is reached when every measured joint is this close
            to the final command.
        settle_timeout_s: time after the planned end for the measured joints to settle.
        joint_state_timeout_s: a goal is refused when the last joint state is older.
        servo_lag_s: time constant of the robot's joint position servo (first-order lag). Each
            command leads the planned position by `servo_lag_s × planned velocity`, the inverse
            of the lag, so the measured arm follows the plan instead of trailing it by
            velocity × lag; without it a stop lets the arm coast through that lag (≈ 170 ms to
            rest in the sim). 0.05 s matches the sim bridge's `servo_time_constant_s`; set it to
            the identified value on hardware, 0 disables the lead.
        posture_rad: posture the IK regularises toward (rad, the arm's joints in order).

    The defaults are the default arm's; `from_dict(values, robot)` takes the posture, the
    workspace, the velocity scale and the acceleration and jerk limits from the robot's
    description (`handover_model.robots`) unless the profile sets them.
    """

    rate_hz: float = 100.0
    status_rate_hz: float = 50.0
    workspace_min_m: tuple[float, float, float] = (0.20, -1.30, -0.35)
    workspace_max_m: tuple[float, float, float] = (1.30, 0.30, 0.80)
    position_tolerance_m: float = 0.001
    orientation_tolerance_rad: float = math.radians(1.0)
    transfer_end_tolerance_m: float = 0.01
    ik_max_iterations: int = 300
    ik_step_s: float = 0.1
    ik_no_progress_iterations: int = 25
    ik_no_progress_ratio: float = 0.05
    ik_restarts: int = 8
    ik_restart_seed: int = 0
    posture_weight: float = 1e-5
    tracking_tolerance_m: float = 0.01
    tracking_tolerance_rad: float = math.radians(3.0)
    velocity_scale: float = 1.0
    joint_acceleration_rad_s2: float = 3.0
    joint_jerk_rad_s3: float = 30.0
    stop_acceleration_rad_s2: float = 40.0
    stop_jerk_rad_s3: float = 4000.0
    default_normalized_peak_speed_1_s: float = 1.5
    max_tool_speed_m_s: float = 1.0
    min_duration_s: float = 0.3
    receiver_zone_radius_m: float = 0.30
    receiver_zone_speed_m_s: float = 0.25
    reach_joint_tolerance_rad: float = 0.01
    settle_timeout_s: float = 3.0
    joint_state_timeout_s: float = 0.5
    servo_lag_s: float = 0.05
    posture_rad: tuple[float, ...] = field(
        default=(0.0, -0.55, 0.0, 1.28, 0.0, 0.26, 0.0)
    )

    def __post_init__(self) -> None:
        positive = [
            "rate_hz",
            "status_rate_hz",
            "position_tolerance_m",
            "orientation_tolerance_rad",
            "transfer_end_tolerance_m",
            "ik_step_s",
            "ik_no_progress_ratio",
            "tracking_tolerance_m",
            "tracking_tolerance_rad",
            "velocity_scale",
            "joint_acceleration_rad_s2",
            "joint_jerk_rad_s3",
            "stop_acceleration_rad_s2",
            "stop_jerk_rad_s3",
            "default_normalized_peak_speed_1_s",
            "max_tool_speed_m_s",
            "min_duration_s",
            "receiver_zone_radius_m",
            "receiver_zone_speed_m_s",
            "reach_joint_tolerance_rad",
            "settle_timeout_s",
            "joint_state_timeout_s",
        ]
        for name in positive:
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise MotionConfigError(f"motion config {name} must be a number, got {value!r}")
            if not math.isfinite(value) or value <= 0.0:
                raise MotionConfigError(f"motion config {name} must be finite and > 0, got {value}")
        if not isinstance(self.servo_lag_s, (int, float)) or not (
            math.isfinite(self.servo_lag_s) and 0.0 <= self.servo_lag_s <= 1.0
        ):
            raise MotionConfigError(f"motion config servo_lag_s must be in [0, 1] s, got {self.servo_lag_s!r}")
        if self.velocity_scale > 1.0:
            raise MotionConfigError(
                f"motion config velocity_scale must be in (0, 1] (fraction of the URDF limits), "
                f"got {self.velocity_scale}"
            )
        for name, minimum in (("ik_max_iterations", 1), ("ik_no_progress_iterations", 1),
                              ("ik_restarts", 0), ("ik_restart_seed", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < minimum:
                raise MotionConfigError(f"motion config {name} must be an integer >= {minimum}, got {value!r}")
        if not isinstance(self.posture_weight, (int, float)) or not (
            math.isfinite(self.posture_weight) and self.posture_weight >= 0.0
        ):
            raise MotionConfigError(
                f"motion config posture_weight must be finite and >= 0, got {self.posture_weight!r}"
            )
        lo, hi = self.workspace_min_m, self.workspace_max_m
        if len(lo) != 3 or len(hi) != 3 or not all(a < b for a, b in zip(lo, hi)):
            raise MotionConfigError(
                f"motion config workspace_min_m {lo} must be 3 numbers each below workspace_max_m {hi}"
            )
        if len(self.posture_rad) < 5 or not all(math.isfinite(v) for v in self.posture_rad):
            raise MotionConfigError(
                f"motion config posture_rad needs one finite angle per arm joint, got {self.posture_rad!r}"
            )

    @property
    def period_s(self) -> float:
        """Control period, s."""
        return 1.0 / self.rate_hz

    @classmethod
    def from_dict(cls, values: dict[str, Any] | None, robot: RobotDescription | None = None) -> MotionConfig:
        """Build from a profile's config table; unknown keys are an error (typos show up).
        With `robot`, the keys the table leaves out that the arm describes come from it.

        Raises:
            MotionConfigError: unknown key or invalid value.
        """
        values = dict(values or {})
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known)
        if unknown:
            raise MotionConfigError(
                f"unknown motion config key(s) {unknown}; known keys: {sorted(known)}"
            )
        for key in ("workspace_min_m", "workspace_max_m", "posture_rad"):
            if key in values:
                try:
                    values[key] = tuple(float(v) for v in values[key])
                except (TypeError, ValueError) as exc:
                    raise MotionConfigError(f"motion config {key} must be a list of numbers") from exc
        if robot is not None:
            from_robot = {"posture_rad": robot.ready_rad, "workspace_min_m": robot.workspace_min_m,
                          "workspace_max_m": robot.workspace_max_m, "velocity_scale": robot.velocity_scale,
                          "joint_acceleration_rad_s2": min(robot.acceleration_rad_s2),
                          "joint_jerk_rad_s3": min(robot.jerk_rad_s3)}
            values = {**from_robot, **values}
        if robot is not None and len(values["posture_rad"]) != robot.dof:
            raise MotionConfigError(f"motion config posture_rad needs {robot.dof} angles "
                                    f"({', '.join(robot.joints)}), got {len(values['posture_rad'])}")
        try:
            return cls(**values)
        except TypeError as exc:
            raise MotionConfigError(f"invalid motion config: {exc}") from exc
