"""Pure logic of the Franka backend: the velocity command, the gripper's actions, the robot's
errors in words and the freshness of its state. No I/O, no franky import; callers pass the
local monotonic time (s).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np


def velocity_command(target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None, measured_rad: np.ndarray,
                     gain_per_s: float, velocity_limit_rad_s: np.ndarray) -> np.ndarray:
    """The joint velocities (rad/s) sent to the robot for one bridge tick: the feed-forward
    plus `gain_per_s` × the position error, each joint clipped to ± its velocity limit (the
    robot's own trajectory generator then keeps its acceleration and jerk limits)."""
    velocity = gain_per_s * (np.asarray(target_rad, float) - np.asarray(measured_rad, float))
    if feedforward_rad_s is not None:
        velocity = velocity + np.asarray(feedforward_rad_s, float)
    return np.clip(velocity, -velocity_limit_rad_s, velocity_limit_rad_s)


@dataclass(frozen=True)
class GripAction:
    """What the Franka Hand is asked to do.

    Attributes:
        kind: ``grasp`` (close on the object with `force_n`) or ``open`` (move to full width).
        force_n: grasp force, N (0 for ``open``).
    """

    kind: Literal["grasp", "open"]
    force_n: float = 0.0


class GripPlanner:
    """Turns the stack's grip-force commands (N) into Hand actions.

    The Hand has no force set-point to stream: each grasp is a whole action (close until
    blocked, then hold `force_n`). So a force below `min_force_n` opens the hand at once; a
    force above it starts a grasp, clipped to `max_force_n`; a later change of force starts a
    new grasp only when it differs by more than `deadband_n` and `min_interval_s` has passed
    since the last one. An open is never delayed or repeated.
    """

    def __init__(self, max_force_n: float, min_force_n: float, deadband_n: float, min_interval_s: float) -> None:
        self.max_force_n = max_force_n
        self.min_force_n = min_force_n
        self.deadband_n = deadband_n
        self.min_interval_s = min_interval_s
        self._last: GripAction | None = None
        self._last_s = -math.inf
        self.clipped = 0

    def plan(self, grip_force_n: float, now_s: float) -> GripAction | None:
        """The action for a grip command of `grip_force_n` (N) at `now_s`, or None (nothing
        new to send). A non-finite force opens the hand."""
        force = float(grip_force_n)
        if not math.isfinite(force) or force < self.min_force_n:
            action = GripAction("open")
            if self._last == action:
                return None
        else:
            if force > self.max_force_n:
                self.clipped += 1
                force = self.max_force_n
            action = GripAction("grasp", force)
            last = self._last
            if last is not None and last.kind == "grasp":
                if abs(force - last.force_n) <= self.deadband_n or now_s - self._last_s < self.min_interval_s:
                    return None
        self._last, self._last_s = action, now_s
        return action


#: libfranka's error flags, grouped by what a user should check (the rest: "other").
ERROR_GROUPS: dict[str, tuple[str, ...]] = {
    "collision reflex (the robot felt more torque or force than its thresholds: check the workspace)": (
        "joint_reflex", "cartesian_reflex", "tau_j_range_violation", "instability_detected"),
    "limit (a joint position, velocity or power limit: check the commanded trajectory)": (
        "joint_position_limits_violation", "joint_velocity_violation", "cartesian_velocity_violation",
        "cartesian_position_limits_violation", "self_collision_avoidance_violation", "power_limit_violation",
        "joint_motion_generator_position_limits_violation", "joint_motion_generator_velocity_limits_violation",
        "joint_motion_generator_velocity_discontinuity", "joint_motion_generator_acceleration_discontinuity",
        "joint_move_in_wrong_direction"),
    "communication (packets lost on the FCI link: check the network and the real-time kernel)": (
        "communication_constraints_violation",),
}


def describe_errors(active: Iterable[str]) -> str:
    """One line naming the robot's active error flags and what to check (empty: none)."""
    active = list(active)
    if not active:
        return ""
    parts = []
    seen: set[str] = set()
    for meaning, flags in ERROR_GROUPS.items():
        hit = [f for f in active if f in flags]
        if hit:
            parts.append(f"{meaning}: {', '.join(hit)}")
            seen.update(hit)
    rest = [f for f in active if f not in seen]
    if rest:
        parts.append(f"other: {', '.join(rest)}")
    return "; ".join(parts)


def active_flags(errors: object, names: Iterable[str]) -> list[str]:
    """The names among `names` whose attribute is True on `errors` (libfranka's ``Errors``)."""
    return [n for n in names if getattr(errors, n, False) is True]


class StateClock:
    """Whether the robot's state is still coming: its own clock (ms) must advance.

    Args:
        lost_after_s: no advance for this long (local monotonic s) means the robot is lost.
    """

    def __init__(self, lost_after_s: float) -> None:
        self.lost_after_s = lost_after_s
        self._robot_ms: int | None = None
        self._advanced_s = -math.inf

    def update(self, robot_ms: int, now_s: float) -> None:
        """A state stamped `robot_ms` (the robot's clock, ms) read at `now_s`."""
        if self._robot_ms is None or robot_ms != self._robot_ms:
            self._robot_ms = robot_ms
            self._advanced_s = now_s

    def silent_s(self, now_s: float) -> float:
        """How long the robot's clock has not advanced, s (inf before any state)."""
        return now_s - self._advanced_s

    def lost(self, now_s: float) -> bool:
        return self.silent_s(now_s) > self.lost_after_s


def describe_velocity(names: Iterable[str], velocity_rad_s: np.ndarray, hold_s: float) -> str:
    """The dry run's line for a velocity command that would be sent."""
    joints = " ".join(f"{n}={v:+.4f}" for n, v in zip(names, velocity_rad_s, strict=True))
    return f"JointVelocityMotion rad/s {joints} (held {hold_s * 1e3:.0f} ms)"
