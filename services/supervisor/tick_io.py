"""What one sequencer tick reads (`Snapshot`) and what it asks the node to publish (`Actions`).

Pure data: no I/O, no clock. Times are the local monotonic clock (s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from bus_schema.messages import (
    GripperState,
    HumanState,
    JointState,
    MotionStatus,
    ObjectEstimate,
    TransferTarget,
    WristWrench,
)


@dataclass
class Snapshot:
    """What the supervisor knows at one tick: the latest decoded messages and their local
    receive times (monotonic s; −inf when never received)."""

    now_s: float
    human: HumanState | None = None
    human_rx_s: float = -math.inf
    obj: ObjectEstimate | None = None
    obj_rx_s: float = -math.inf
    target: TransferTarget | None = None
    target_rx_s: float = -math.inf
    motion: MotionStatus | None = None
    gripper: GripperState | None = None
    wrench: WristWrench | None = None
    joints: JointState | None = None
    joints_rx_s: float = -math.inf


@dataclass
class Actions:
    """What the node must publish after a call: a motion goal, a stop, an episode summary
    (fields without header), and whether the state changed."""

    goal: dict[str, Any] | None = None
    goal_repeated: bool = False  # `goal` is a copy of one already sent (no report on it yet)
    stop: dict[str, Any] | None = None
    summary: dict[str, Any] | None = None
    state_changed: bool = False

    def merge(self, other: Actions) -> Actions:
        if other.goal:
            self.goal_repeated = other.goal_repeated
        self.goal = other.goal or self.goal
        self.stop = other.stop or self.stop
        self.summary = other.summary or self.summary
        self.state_changed = self.state_changed or other.state_changed
        return self
