"""The gripper service's command, state and release event (forces in N)."""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta

from bus_schema.messages.header import Message
from bus_schema.types import ForceN, NonNegForceN, Text

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
