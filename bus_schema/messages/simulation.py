"""Ground truth from the simulators (never used for control; for tests and review)."""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.types import U63, ForceN, NonNegForceN, ServiceName, SpeedMS, Vec3M, Vec3VelocityMS

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


class ClockGrant(Message, frozen=True, kw_only=True):
    """The simulation clock's next step (the bridge's simulation owns time), sent on
    `sim/clock/<participant>` to each participant it names.

    A participant sets its time to `time_ns`, runs its work for that time and answers with a
    `ClockReady`.

    Attributes:
        step: number of the step (0 for the first).
        time_ns: simulated time since the run's start, ns.
        due: the participants that must act at this step (an event step names all of them).
    """

    step: U63
    time_ns: U63
    due: Annotated[list[ServiceName], Meta(max_length=64)] = []


class ClockReady(Message, frozen=True, kw_only=True):
    """A participant of the simulation clock is done up to `done_ns` and next needs the
    clock at `next_ns` (`sim/clock_ready/<service>`).

    Attributes:
        done_ns: the simulated time whose work is finished, ns.
        next_ns: the simulated time the participant must next act at, ns.
        events: it sent an event (a goal, a stop, a release) in this step: every participant
            gets a step 1 µs later to act on it, as the wall clock's event wake-ups do.
        leaving: it leaves the clock (shutting down): never wait for it again.
        pid: its process id (the clock's owner asks the kernel whether a quiet one is stopped).
    """

    done_ns: U63
    next_ns: U63
    events: bool = False
    leaving: bool = False
    pid: Annotated[int, Meta(ge=0, le=(1 << 31) - 1)] = 0
