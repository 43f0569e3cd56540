"""Every message on the handover bus: the public index of the bus contract.

All messages are frozen msgspec Structs encoded as MessagePack maps, so a field added later
(always with a default) is ignored by older decoders and filled with its default by newer
ones. Every message starts with the common header (`seq`, `stamp_ns`, `source`).

Frames (DESIGN §5):
- `base`: the scene's base frame, x forward, y left, z up (metres).
- task plane: x from giver to receiver, z up, origin at the middle of the table top.
- gripper frame of the transfer loop (thesis Fig. 15): x along the pull toward the receiver,
  y DOWN (a positive `accel_y_m_s2` means the object accelerates downward), z = x × y.

The types are defined by area, one module each: `header` (the common header), `robot` (arm
and wrist sensors), `perception`, `motion` (planner's transfer point and the motion
service), `gripper`, `supervisor` (sequencer and heartbeats) and `simulation` (ground
truth). Import them from here: ``from bus_schema.messages import JointState``.
"""

from bus_schema.messages.header import Message
from bus_schema.messages.robot import JointCommand, JointState, ObjectMotion, WristWrench
from bus_schema.messages.perception import (
    SKELETON_JOINTS,
    DepthImage,
    HandCorrection,
    HumanState,
    ObjectEstimate,
    Posture,
    Skeleton,
    SkeletonJoint,
    SkeletonJointName,
)
from bus_schema.messages.motion import (
    ConstraintName,
    MotionGoal,
    MotionKind,
    MotionState,
    MotionStatus,
    MotionStop,
    TransferTarget,
)
from bus_schema.messages.gripper import GripperCommand, GripperMode, GripperState, ReleaseEvent
from bus_schema.messages.supervisor import (
    PHASES_OUTSIDE_EPISODE,
    SUPERVISOR_STATE_FRESH_S,
    EpisodeOutcome,
    EpisodeSummary,
    GripRequest,
    Heartbeat,
    SupervisorPhase,
    SupervisorState,
)
from bus_schema.messages.simulation import ClockGrant, ClockReady, Holder, KinectTruth, SimTruth
from bus_schema.types import MAX_JOINTS, AngleRad, DistanceM, ForceN, PositionM

__all__ = [
    "MAX_JOINTS",
    "PHASES_OUTSIDE_EPISODE",
    "SKELETON_JOINTS",
    "SUPERVISOR_STATE_FRESH_S",
    "AngleRad",
    "ConstraintName",
    "DepthImage",
    "DistanceM",
    "ClockGrant",
    "ClockReady",
    "EpisodeOutcome",
    "EpisodeSummary",
    "ForceN",
    "GripRequest",
    "GripperCommand",
    "GripperMode",
    "GripperState",
    "HandCorrection",
    "Heartbeat",
    "Holder",
    "HumanState",
    "JointCommand",
    "JointState",
    "KinectTruth",
    "Message",
    "MotionGoal",
    "MotionKind",
    "MotionState",
    "MotionStatus",
    "MotionStop",
    "ObjectEstimate",
    "ObjectMotion",
    "Posture",
    "PositionM",
    "ReleaseEvent",
    "SimTruth",
    "Skeleton",
    "SkeletonJoint",
    "SkeletonJointName",
    "SupervisorPhase",
    "SupervisorState",
    "TransferTarget",
    "WristWrench",
]
