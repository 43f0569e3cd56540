"""Every message on the handover bus.

All messages are frozen msgspec Structs encoded as MessagePack maps, so a field added later
(always with a default) is ignored by older decoders and filled with its default by newer
ones. Every message starts with the common header (`seq`, `stamp_ns`, `source`).

Frames (DESIGN §5):
- `base`: Baxter's base frame, x forward, y left, z up (metres).
- task plane: x from giver to receiver, z up, origin at the middle of the table top.
- gripper frame of the transfer loop (thesis Fig. 15): x along the pull toward the receiver,
  y DOWN (a positive `accel_y_m_s2` means the object accelerates downward), z = x × y.
"""

from __future__ import annotations

from typing import Annotated, Literal

import msgspec
from msgspec import Meta

from bus_schema.types import (
    MAX_JOINTS,
    MAX_PAYLOAD_BYTES,
    AccelMS2,
    AngleRad,
    Cost,
    DistanceM,
    DurationS,
    ForceN,
    Fraction,
    Identifier,
    JointEfforts,
    JointNames,
    JointPositions,
    JointVelocities,
    MassKg,
    NonNegForceN,
    PositionM,
    QuaternionXYZW,
    Seq,
    ServiceName,
    SpeedMS,
    StampNs,
    Text,
    U63,
    Vec2M,
    Vec3ForceN,
    Vec3M,
    Vec3TorqueNm,
    Vec3VelocityMS,
    VelocityMS,
)


class Message(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=False):
    """Common header of every message.

    Attributes:
        seq: per-publisher sequence number, starts at 0 and increases by one per message.
        stamp_ns: sender's wall clock (`time.time_ns()`), strictly increasing within one
            sending process even when the host's clock steps back
            (`services.runtime.stamps`). Freshness is judged by local receive time, never by
            comparing clocks; two messages of one source may be ordered by it (a motion goal
            against a stop: `services.motion.goal_filter`).
        source: name of the publishing service (e.g. ``bridge``).
    """

    seq: Seq
    stamp_ns: StampNs
    source: ServiceName


# --------------------------------------------------------------------------- robot


class JointState(Message, frozen=True, kw_only=True):
    """Measured joint state of the arm (100 Hz).

    Attributes:
        names: joint names (e.g. ``right_s0`` … ``right_w2``).
        position_rad, velocity_rad_s, effort_nm: per joint, same order as `names`.
        holding: True while the arm holds position because no fresh command arrived within
            the command time-out (200 ms) or a command was rejected.
        backend: ``sim`` or ``baxter``.
        enabled: the robot is enabled (always True in simulation).
    """

    names: JointNames
    position_rad: JointPositions
    velocity_rad_s: JointVelocities
    effort_nm: JointEfforts = []
    holding: bool = True
    backend: Literal["sim", "baxter"] = "sim"
    enabled: bool = True


class JointCommand(Message, frozen=True, kw_only=True):
    """Joint position command (100 Hz stream from the motion service).

    Attributes:
        names: joint names the positions refer to.
        position_rad: target joint positions (rad).
        velocity_rad_s: optional feed-forward velocities (rad/s); empty when not given.
        goal_id: the motion goal this command belongs to.
    """

    names: JointNames
    position_rad: JointPositions
    velocity_rad_s: JointVelocities = []
    goal_id: Annotated[str, Meta(max_length=64)] = ""


# --------------------------------------------------------------------------- sensors


class WristWrench(Message, frozen=True, kw_only=True):
    """Wrist force/torque sensor reading at the base of the gripper (100 Hz).

    Attributes:
        force_n: (F_sx, F_sy, F_sz) in the gripper frame of the transfer loop
            (x toward the receiver, y down), N. Gravity of the gripper is compensated; the
            held object's weight is not.
        torque_nm: torques about the same axes, N m.
    """

    force_n: Vec3ForceN
    torque_nm: Vec3TorqueNm = (0.0, 0.0, 0.0)


class ObjectMotion(Message, frozen=True, kw_only=True):
    """Optical (mouse-type) sensor on the finger pad, with the derived estimates (≤ 1 kHz).

    Attributes:
        displacement_counts: relative displacement (x, y) since the previous sample, in
            sensor counts (gripper frame: x toward the receiver, y down).
        counts_per_m: sensor resolution (e.g. 400 cpi ≈ 15748 counts/m).
        dt_s: time covered by this sample, s.
        surface_valid: the object surface is over the sensor (False: counts are zero and the
            estimates are not to be trusted).
        velocity_m_s: estimated slip velocity (x, y), m/s.
        accel_y_m_s2: estimated acceleration along y (down positive), m/s², as used by the
            thesis's fail-safe law.
    """

    displacement_counts: tuple[
        Annotated[int, Meta(ge=-32768, le=32767)], Annotated[int, Meta(ge=-32768, le=32767)]
    ]
    counts_per_m: Annotated[float, Meta(gt=0.0, le=1e7)]
    dt_s: Annotated[float, Meta(gt=0.0, le=1.0)]
    surface_valid: bool = True
    velocity_m_s: tuple[VelocityMS, VelocityMS] = (0.0, 0.0)
    accel_y_m_s2: AccelMS2 = 0.0


# --------------------------------------------------------------------------- perception

SkeletonJointName = Literal[
    "head",
    "neck",
    "torso",
    "left_shoulder",
    "left_elbow",
    "left_hand",
    "right_shoulder",
    "right_elbow",
    "right_hand",
    "left_hip",
    "left_knee",
    "left_foot",
    "right_hip",
    "right_knee",
    "right_foot",
]
SKELETON_JOINTS: tuple[SkeletonJointName, ...] = (
    "head",
    "neck",
    "torso",
    "left_shoulder",
    "left_elbow",
    "left_hand",
    "right_shoulder",
    "right_elbow",
    "right_hand",
    "left_hip",
    "left_knee",
    "left_foot",
    "right_hip",
    "right_knee",
    "right_foot",
)


class SkeletonJoint(msgspec.Struct, frozen=True, kw_only=True):
    """One tracked joint: OpenNI name, position in the `base` frame (m), confidence 0..1."""

    name: SkeletonJointName
    position_m: Vec3M
    confidence: Fraction = 1.0


class Skeleton(Message, frozen=True, kw_only=True):
    """OpenNI-style 15-joint skeleton from the (simulated) Kinect, 30 Hz.

    Attributes:
        tracked: a person is tracked; `joints` is empty when not.
        user_id: tracker's id of the person.
        joints: up to 15 joints, positions in the `base` frame.
    """

    tracked: bool
    user_id: Annotated[int, Meta(ge=0, le=65535)] = 0
    joints: Annotated[list[SkeletonJoint], Meta(max_length=len(SKELETON_JOINTS))] = []


class DepthImage(Message, frozen=True, kw_only=True):
    """Depth image from the (simulated) Kinect, 30 Hz.

    Attributes:
        width, height: image size in pixels.
        depth_mm: row-major little-endian uint16 depths in millimetres (0 = no reading);
            exactly ``2 * width * height`` bytes.
        fx, fy, cx, cy: pinhole intrinsics in pixels.
        camera_position_m, camera_orientation_xyzw: pose of the optical frame (z forward,
            x right, y down) in the `base` frame.
    """

    width: Annotated[int, Meta(ge=1, le=1024)]
    height: Annotated[int, Meta(ge=1, le=1024)]
    depth_mm: Annotated[bytes, Meta(max_length=MAX_PAYLOAD_BYTES - 4096)]
    fx: Annotated[float, Meta(gt=0.0, le=1e5)]
    fy: Annotated[float, Meta(gt=0.0, le=1e5)]
    cx: Annotated[float, Meta(ge=-1e5, le=1e5)]
    cy: Annotated[float, Meta(ge=-1e5, le=1e5)]
    camera_position_m: Vec3M = (0.0, 0.0, 0.0)
    camera_orientation_xyzw: QuaternionXYZW = (0.0, 0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if len(self.depth_mm) != 2 * self.width * self.height:
            raise ValueError(
                f"depth_mm has {len(self.depth_mm)} bytes, expected 2*width*height = "
                f"{2 * self.width * self.height}"
            )


Posture = Literal["standing", "sitting", "unknown"]
HandCorrection = Literal["none", "lag", "proximity_hold", "lag+proximity_hold"]


class HumanState(Message, frozen=True, kw_only=True):
    """Receiver state from the tracker (corrected hand, body dimensions), `base` frame.

    Attributes:
        tracked: a person is tracked; the other fields are meaningless when False.
        hand_position_m: corrected hand position (the hand that receives).
        hand_raw_position_m: the tracker's hand estimate before correction.
        correction: which correction acted on this frame.
        torso_position_m: torso joint position.
        height_m, arm_span_m, shoulder_height_m: body dimensions estimated over frames.
        posture: standing or sitting.
        weight_kg: body weight from the receiver's profile (a camera cannot weigh).
        frame_age_s: age of the skeleton frame this state comes from, s (local clock).
    """

    tracked: bool
    hand_position_m: Vec3M = (0.0, 0.0, 0.0)
    hand_raw_position_m: Vec3M = (0.0, 0.0, 0.0)
    correction: HandCorrection = "none"
    torso_position_m: Vec3M = (0.0, 0.0, 0.0)
    height_m: Annotated[float, Meta(ge=0.0, le=3.0)] = 0.0
    arm_span_m: Annotated[float, Meta(ge=0.0, le=3.5)] = 0.0
    shoulder_height_m: Annotated[float, Meta(ge=0.0, le=3.0)] = 0.0
    posture: Posture = "unknown"
    weight_kg: Annotated[float, Meta(ge=0.0, le=400.0)] = 0.0
    frame_age_s: DurationS = 0.0


class ObjectEstimate(Message, frozen=True, kw_only=True):
    """Object found on the table from depth (`base` frame).

    Attributes:
        found: an object was found.
        position_m: centre of the object.
        size_m: bounding-box extents (x, y, z).
        mass_kg: mass from the task description (a camera cannot weigh).
    """

    found: bool
    position_m: Vec3M = (0.0, 0.0, 0.0)
    size_m: tuple[DistanceM, DistanceM, DistanceM] = (0.0, 0.0, 0.0)
    mass_kg: MassKg = 0.0


# --------------------------------------------------------------------------- planner

ConstraintName = Annotated[str, Meta(max_length=64)]


class TransferTarget(Message, frozen=True, kw_only=True):
    """Object transfer point from the DJT planner.

    Attributes:
        position_task_m: (x, z) in the task plane (x giver→receiver, z up, origin at the
            middle of the table top).
        position_base_m: the same point in Baxter's `base` frame.
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


# --------------------------------------------------------------------------- motion

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


# --------------------------------------------------------------------------- gripper

GripperMode = Literal["grasp", "slip", "release", "hold"]


class GripperCommand(Message, frozen=True, kw_only=True):
    """Command to the gripper actuator.

    Attributes:
        grip_force_n: commanded grip normal force, N (clamped to ≤ 140 N by the service).
        position_m: finger position that yields this force through the thesis's spring
            (eq 3.21), m from the fully open position (never negative).
        mode: controller mode when the command was made.
    """

    grip_force_n: Annotated[float, Meta(ge=0.0, le=140.0)]
    position_m: Annotated[float, Meta(ge=0.0, le=1.0)] = 0.0
    mode: GripperMode = "grasp"


class GripperState(Message, frozen=True, kw_only=True):
    """Gripper service state.

    Attributes:
        mode: grasp, slip, release, or hold (holding because sensor data is stale/bad).
        grip_force_n: commanded grip force, N.
        measured_grip_force_n: grip force the actuator reports, N (0 when unknown).
        controller: name of the running controller (e.g. ``FS1``).
        sensors_fresh: wrench and motion data are fresh.
        released: the object has been fully released.
        reason: explanation for ``hold`` (e.g. ``wrist_wrench stale for 0.31 s``).
    """

    mode: GripperMode
    grip_force_n: NonNegForceN
    measured_grip_force_n: NonNegForceN = 0.0
    controller: Annotated[str, Meta(max_length=64)] = ""
    sensors_fresh: bool = True
    released: bool = False
    reason: Text = ""


class ReleaseEvent(Message, frozen=True, kw_only=True):
    """The gripper has fully released the object (triggers the release interrupt).

    Attributes:
        grip_force_n: commanded grip force at release, N.
        pull_force_n: receiver's pull F_sx at release, N.
        controller: controller that released.
    """

    grip_force_n: NonNegForceN
    pull_force_n: ForceN = 0.0
    controller: Annotated[str, Meta(max_length=64)] = ""


# --------------------------------------------------------------------------- supervisor

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


# --------------------------------------------------------------------------- runtime


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


# --------------------------------------------------------------------------- simulation

Holder = Literal["gripper", "receiver", "both", "table", "none"]


class SimTruth(Message, frozen=True, kw_only=True):
    """Ground truth from the simulator (never used for control; for tests and review).

    Attributes:
        object_position_m: object centre in the `base` frame.
        object_velocity_m_s: object velocity in the `base` frame.
        held_by: who supports the object.
        dropped: the object fell with nobody holding it.
        slip_m: slip distance of the object relative to the pads (gripper frame y, down +;
            signed: a receiver who lifts the object moves it up).
        grip_force_n: actual grip normal force, N.
        receiver_hand_position_m: receiver hand (true) in the `base` frame.
        receiver_pull_n: receiver's pull on the object along x, N (signed: a push is negative).
        tool_position_m: true gripper position in the `base` frame.
        tool_speed_m_s: true gripper speed, m/s.
    """

    object_position_m: Vec3M = (0.0, 0.0, 0.0)
    object_velocity_m_s: Vec3VelocityMS = (0.0, 0.0, 0.0)
    held_by: Holder = "gripper"
    dropped: bool = False
    slip_m: Annotated[float, Meta(ge=-10.0, le=10.0)] = 0.0
    grip_force_n: NonNegForceN = 0.0
    receiver_hand_position_m: Vec3M = (0.0, 0.0, 0.0)
    receiver_pull_n: ForceN = 0.0
    tool_position_m: Vec3M = (0.0, 0.0, 0.0)
    tool_speed_m_s: SpeedMS = 0.0


class KinectTruth(Message, frozen=True, kw_only=True):
    """Ground truth of the body the simulated Kinect rendered in its latest frame (never
    used for control; for tests and review): 30 Hz while the body moves, 10 Hz while it is
    still.

    Attributes:
        hand_position_m: true position of the receiver's right (receiving) hand, `base` frame.
        torso_position_m: true torso position of the same body, `base` frame.
    """

    hand_position_m: Vec3M = (0.0, 0.0, 0.0)
    torso_position_m: Vec3M = (0.0, 0.0, 0.0)


__all__ = [
    "MAX_JOINTS",
    "SKELETON_JOINTS",
    "AngleRad",
    "DepthImage",
    "EpisodeSummary",
    "Heartbeat",
    "GripperCommand",
    "GripperState",
    "HumanState",
    "JointCommand",
    "JointState",
    "KinectTruth",
    "Message",
    "MotionGoal",
    "MotionStatus",
    "MotionStop",
    "ObjectEstimate",
    "ObjectMotion",
    "PositionM",
    "ReleaseEvent",
    "SimTruth",
    "Skeleton",
    "SkeletonJoint",
    "SupervisorState",
    "TransferTarget",
    "WristWrench",
    "ForceN",
    "DistanceM",
]
