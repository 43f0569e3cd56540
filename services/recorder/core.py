"""Pure pieces of the recorder's mapping from bus messages to Rerun entities (no I/O).

- `numeric_fields`: the numeric series of a message, by field path (``force_n/1``): the names
  `readback.read_scalars` gives the series of ``bus/<key>`` (see `bus_columns`);
- events: `event_text`, `event_key` (what must change for an event to be logged again),
  `event_is_warning`;
- the 3-D look of one-point entities (`POINT_STYLES`), skeleton bones, gripper mode codes.

Conventions: the 3-D world is the scene's `base` frame (x forward, y left, z up, metres) under
``world/…``; supervisor, motion and gripper events are text under ``events``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import msgspec

from bus_schema import messages as m

Vec3 = tuple[float, float, float]

#: Message fields that are header or bookkeeping, not data to plot.
_SKIP_FIELDS = frozenset({"seq", "stamp_ns", "source", "depth_mm", "names", "joints"})

#: Messages that make lines of the event log.
EVENT_TYPES = (m.SupervisorState, m.MotionStatus, m.MotionStop, m.ReleaseEvent, m.GripperState)

#: Gripper mode as a number for the mode series (``signals/gripper_mode``).
GRIPPER_MODE_CODE: dict[str, float] = {"grasp": 0.0, "slip": 1.0, "release": 2.0, "hold": 3.0}


@dataclass(frozen=True)
class PointStyle:
    """Static look of a one-point-per-message entity."""

    radius_m: float
    color_rgb: tuple[int, int, int]
    label: str


#: Every one-point-per-message entity (`derived`), with its static look.
POINT_STYLES: dict[str, PointStyle] = {
    "world/truth/object": PointStyle(0.035, (230, 120, 20), "object (truth)"),
    "world/truth/receiver_hand": PointStyle(0.02, (150, 150, 150), "receiver hand (truth)"),
    "world/tool": PointStyle(0.02, (60, 120, 255), "tool"),
    "world/human/hand_corrected": PointStyle(0.03, (40, 200, 80), "hand (corrected)"),
    "world/human/hand_raw": PointStyle(0.02, (200, 60, 60), "hand (raw)"),
    "world/transfer_target": PointStyle(0.035, (250, 200, 0), "transfer target"),
    "world/motion/goal": PointStyle(0.025, (170, 60, 220), "motion goal"),
}

#: OpenNI skeleton bones (pairs of joint names) drawn as line strips.
SKELETON_BONES: tuple[tuple[str, str], ...] = (
    ("head", "neck"), ("neck", "torso"),
    ("neck", "left_shoulder"), ("left_shoulder", "left_elbow"), ("left_elbow", "left_hand"),
    ("neck", "right_shoulder"), ("right_shoulder", "right_elbow"), ("right_elbow", "right_hand"),
    ("torso", "left_hip"), ("left_hip", "left_knee"), ("left_knee", "left_foot"),
    ("torso", "right_hip"), ("right_hip", "right_knee"), ("right_knee", "right_foot"),
    ("left_hip", "right_hip"),
)


def numeric_fields(msg: msgspec.Struct, prefix: str = "") -> Iterator[tuple[str, float]]:
    """(field path, value) for every number and bool in `msg` (recursively, tuples indexed)."""
    for name in msg.__struct_fields__:
        if name in _SKIP_FIELDS:
            continue
        yield from _numeric(getattr(msg, name), f"{prefix}{name}")


def _numeric(value: Any, path: str) -> Iterator[tuple[str, float]]:
    if isinstance(value, bool):
        yield path, float(value)
    elif isinstance(value, (int, float)):
        yield path, float(value)
    elif isinstance(value, (tuple, list)) and len(value) <= 16:
        for i, item in enumerate(value):
            yield from _numeric(item, f"{path}/{i}")
    elif isinstance(value, msgspec.Struct):
        yield from numeric_fields(value, f"{path}/")


def event_text(msg: m.Message) -> str | None:
    """One line for the event log, or None when `msg` is not an event."""
    if isinstance(msg, m.SupervisorState):
        return f"supervisor: {msg.phase}" + (f" ({msg.reason})" if msg.reason else "")
    if isinstance(msg, m.MotionStatus):
        return f"motion: {msg.state} {msg.goal_id}" + (f" ({msg.reason})" if msg.reason else "")
    if isinstance(msg, m.MotionStop):
        return f"STOP ({'protective' if msg.protective else 'release'}): {msg.reason}"
    if isinstance(msg, m.ReleaseEvent):
        return f"RELEASE by {msg.controller}: grip {msg.grip_force_n:.1f} N, pull {msg.pull_force_n:.1f} N"
    if isinstance(msg, m.GripperState):
        return f"gripper: {msg.mode}" + (f" ({msg.reason})" if msg.reason else "")
    return None


def event_key(msg: m.Message) -> tuple[Any, ...] | None:
    """What must change for an event message to be logged again as text (None: not an event)."""
    if isinstance(msg, m.SupervisorState):
        return (msg.phase, msg.reason)
    if isinstance(msg, m.MotionStatus):
        return (msg.state, msg.goal_id, msg.reason)
    if isinstance(msg, m.GripperState):
        return (msg.mode, msg.reason)
    if isinstance(msg, (m.MotionStop, m.ReleaseEvent)):
        return (msg.source, msg.seq)
    return None


def skeleton_bones(joints: list[m.SkeletonJoint]) -> list[list[Vec3]]:
    """Bones between the tracked joints, each a two-point strip in the `base` frame (m)."""
    where = {j.name: j.position_m for j in joints}
    return [[where[a], where[b]] for a, b in SKELETON_BONES if a in where and b in where]


def event_is_warning(msg: m.Message) -> bool:
    """Stops and releases are warnings in the event log; the rest is information."""
    return isinstance(msg, (m.MotionStop, m.ReleaseEvent))
