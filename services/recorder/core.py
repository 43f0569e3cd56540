"""Pure mapping from bus messages to Rerun entities (no I/O).

`message_rows(topic, msg)` returns what one message adds to the recording, split by how it is
written:

- ``scalars``: (entity, value) — one row per message, written in columns (batched);
- ``points``: (entity, (x, y, z)) — one 3-D point per message in the `base` frame, also
  written in columns; the point's look (radius, colour, label) is static, see `POINT_STYLES`;
- ``logs``: (entity, archetype) — everything else (skeletons, depth, text), logged per message.

Conventions:
- every numeric field of every message becomes a scalar series under
  ``bus/<key suffix>/<field path>`` (nested tuples get an index: ``force_n/1``), so nothing
  on the bus is lost from the recording;
- joints also get ``robot/joint_position/<joint>`` (and velocity, command) series;
- the 3-D world is Baxter's `base` frame (x forward, y left, z up, metres) under ``world/…``;
- supervisor, motion and gripper events are text under ``events``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import msgspec
import rerun as rr

from bus_schema import Topic, messages as m

Vec3 = tuple[float, float, float]

#: Message fields that are header or bookkeeping, not data to plot.
_SKIP_FIELDS = frozenset({"seq", "stamp_ns", "source", "depth_mm", "names", "joints"})

_EVENT_TYPES = (m.SupervisorState, m.MotionStatus, m.MotionStop, m.ReleaseEvent, m.GripperState)

#: Gripper mode as a number for the mode series (``signals/gripper_mode``).
GRIPPER_MODE_CODE: dict[str, float] = {"grasp": 0.0, "slip": 1.0, "release": 2.0, "hold": 3.0}


@dataclass(frozen=True)
class PointStyle:
    """Static look of a one-point-per-message entity."""

    radius_m: float
    color_rgb: tuple[int, int, int]
    label: str


#: Every entity that `message_rows` returns under ``points``, with its look.
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


@dataclass
class MessageRows:
    """What one message adds to the recording (see the module docstring)."""

    scalars: list[tuple[str, float]] = field(default_factory=list)
    points: list[tuple[str, Vec3]] = field(default_factory=list)
    logs: list[tuple[str, Any]] = field(default_factory=list)


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


def message_rows(topic: Topic, msg: m.Message, log_event_text: bool = True) -> MessageRows:
    """Entities to write for one message of `topic` (stateless part; see `review.ReviewState`)."""
    rows = MessageRows()
    base = f"bus/{topic.suffix}"
    rows.scalars = [(f"{base}/{path}", value) for path, value in numeric_fields(msg)]

    if isinstance(msg, m.JointState):
        rows.scalars += [(f"robot/joint_position/{n}", q) for n, q in zip(msg.names, msg.position_rad, strict=False)]
        rows.scalars += [(f"robot/joint_velocity/{n}", v) for n, v in zip(msg.names, msg.velocity_rad_s, strict=False)]
    elif isinstance(msg, m.JointCommand):
        rows.scalars += [(f"robot/joint_command/{n}", q) for n, q in zip(msg.names, msg.position_rad, strict=False)]
    elif isinstance(msg, m.Skeleton):
        if msg.tracked and msg.joints:
            rows.logs.append(("world/skeleton/raw", rr.Points3D(
                [j.position_m for j in msg.joints], labels=[j.name for j in msg.joints], radii=0.02,
                colors=[(200, 60, 60)], show_labels=False)))
            rows.logs.append(("world/skeleton/bones", rr.LineStrips3D(
                skeleton_bones(msg.joints), radii=0.008, colors=[(200, 90, 90)])))
    elif isinstance(msg, m.HumanState):
        if msg.tracked:
            rows.points.append(("world/human/hand_corrected", msg.hand_position_m))
            rows.points.append(("world/human/hand_raw", msg.hand_raw_position_m))
            correction = tuple(c - r for c, r in zip(msg.hand_position_m, msg.hand_raw_position_m, strict=True))
            rows.logs.append(("world/human/hand_correction", rr.Arrows3D(
                origins=[msg.hand_raw_position_m], vectors=[correction], colors=[(40, 200, 80)], radii=0.004)))
    elif isinstance(msg, m.ObjectEstimate):
        if msg.found:
            rows.logs.append(("world/object/estimate", rr.Boxes3D(centers=[msg.position_m], sizes=[msg.size_m],
                                                                  colors=[(230, 120, 20)])))
    elif isinstance(msg, m.TransferTarget):
        rows.points.append(("world/transfer_target", msg.position_base_m))
    elif isinstance(msg, m.MotionGoal):
        if msg.position_base_m is not None:
            rows.points.append(("world/motion/goal", msg.position_base_m))
    elif isinstance(msg, m.GripperState):
        rows.scalars.append(("signals/gripper_mode", GRIPPER_MODE_CODE[msg.mode]))
    elif isinstance(msg, m.SimTruth):
        rows.points.append(("world/truth/object", msg.object_position_m))
        rows.points.append(("world/truth/receiver_hand", msg.receiver_hand_position_m))
        rows.points.append(("world/tool", msg.tool_position_m))
    elif isinstance(msg, m.DepthImage):
        import numpy as np

        depth = np.frombuffer(msg.depth_mm, dtype="<u2").reshape(msg.height, msg.width)
        rows.logs.append(("camera/depth", rr.DepthImage(depth, meter=1000.0)))

    if log_event_text and isinstance(msg, _EVENT_TYPES):
        text = event_text(msg)
        if text:
            level = rr.TextLogLevel.WARN if isinstance(msg, (m.MotionStop, m.ReleaseEvent)) else rr.TextLogLevel.INFO
            rows.logs.append(("events", rr.TextLog(text, level=level)))
    return rows
