"""The reach: the planner's transfer point (task plane and `base` frame, m) and the motion
service's goals, status and stop.
"""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.messages.perception import Posture
from bus_schema.types import (
    Cost,
    DurationS,
    Fraction,
    Identifier,
    JointPositions,
    MassKg,
    QuaternionXYZW,
    SpeedMS,
    Text,
    Vec2M,
    Vec3M,
)

ConstraintName = Annotated[str, Meta(max_length=64)]


class TransferTarget(Message, frozen=True, kw_only=True):
    """Object transfer point from the DJT planner.

    Attributes:
        position_task_m: (x, z) in the task plane (x giver→receiver, z up, origin at the
            middle of the table top).
        position_base_m: the same point in the scene's `base` frame.
        cost: E_DJT at the optimum, N² m².
        active_constraints: constraints active at the optimum (e.g. ``table``,
            ``receiver_reach``).
        reach_duration_s: suggested minimum-jerk reach duration, s.
        peak_speed_m_s: suggested peak hand speed, m/s.
        object_mass_kg: object mass the plan used.
        receiver_posture: the receiver posture the plan used.
    """

    position_task_m: Vec2M
    position_base_m: Vec3M
    cost: Cost = 0.0
    active_constraints: Annotated[list[ConstraintName], Meta(max_length=16)] = []
    reach_duration_s: DurationS = 0.0
    peak_speed_m_s: SpeedMS = 0.0
    object_mass_kg: MassKg = 0.0
    receiver_posture: Posture = "unknown"


MotionKind = Literal["pick", "transfer", "retract", "joint"]


class MotionGoal(Message, frozen=True, kw_only=True):
    """A goal for the motion service.

    Attributes:
        goal_id: identifier echoed in status and joint commands.
        kind: ``pick``/``retract``/``joint`` are jerk-limited joint-space moves (Ruckig);
            ``transfer`` is a straight Cartesian reach with minimum-jerk timing.
        position_base_m: target tool position in the `base` frame (Cartesian kinds).
        orientation_xyzw: target tool orientation; None keeps the object upright.
        joint_target_rad: target joint positions for ``joint`` (and optional for pick/retract).
        duration_s: requested duration (0: derived from `peak_speed_m_s` or the limits).
        peak_speed_m_s: requested peak tool speed (0: default).
        receiver_hand_position_m: last known receiver hand, for the 0.25 m/s cap within 0.3 m.
    """

    goal_id: Identifier
    kind: MotionKind
    position_base_m: Vec3M | None = None
    orientation_xyzw: QuaternionXYZW | None = None
    joint_target_rad: JointPositions = []
    duration_s: DurationS = 0.0
    peak_speed_m_s: SpeedMS = 0.0
    receiver_hand_position_m: Vec3M | None = None


MotionState = Literal["idle", "moving", "reached", "stopped", "failed"]


class MotionStatus(Message, frozen=True, kw_only=True):
    """Motion service status (10–100 Hz and on every change).

    Attributes:
        goal_id: the goal this status refers to ("" when idle).
        state: idle, moving, reached, stopped (after a stop message) or failed.
        reason: why it failed or stopped.
        progress: fraction of the planned duration elapsed.
        tool_speed_m_s: commanded tool speed, m/s.
    """

    goal_id: Annotated[str, Meta(max_length=64)] = ""
    state: MotionState
    reason: Text = ""
    progress: Fraction = 0.0
    tool_speed_m_s: SpeedMS = 0.0


class MotionStop(Message, frozen=True, kw_only=True):
    """Stop all arm motion now (release interrupt or protective stop).

    Attributes:
        reason: why (e.g. ``release``, ``service lost: tracker``).
        protective: a protective stop (a fault), as opposed to the normal release interrupt.
    """

    reason: Text
    protective: bool = False
