"""Pure mapping from bus messages to Rerun entities (no I/O).

`to_rerun(topic, msg)` returns the (entity path, archetype) pairs to log for one message.
Conventions:
- every numeric field of every message becomes a scalar series under
  ``bus/<key suffix>/<field path>`` (nested tuples get an index: ``force_n/1``), so nothing
  on the bus is lost from the recording;
- some messages also get a view of their own: joints as ``robot/joint_position/<joint>``,
  positions in the `base` frame as 3-D points under ``world/…``, supervisor and motion
  events as text under ``events``;
- the 3-D world is Baxter's `base` frame (x forward, y left, z up, metres).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import msgspec
import rerun as rr

from bus_schema import Topic, messages as m

Logged = tuple[str, Any]

#: Message fields that are header or bookkeeping, not data to plot.
_SKIP_FIELDS = frozenset({"seq", "stamp_ns", "source", "depth_mm", "names", "joints"})

_EVENT_TYPES = (m.SupervisorState, m.MotionStatus, m.MotionStop, m.ReleaseEvent, m.GripperState)


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


def _event_text(msg: m.Message) -> str | None:
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


def to_rerun(topic: Topic, msg: m.Message, log_event_text: bool = True) -> list[Logged]:
    """Entities to log for one message of `topic`."""
    out: list[Logged] = []
    base = f"bus/{topic.suffix}"
    for path, value in numeric_fields(msg):
        out.append((f"{base}/{path}", rr.Scalars(value)))

    if isinstance(msg, m.JointState):
        for name, q in zip(msg.names, msg.position_rad, strict=False):
            out.append((f"robot/joint_position/{name}", rr.Scalars(q)))
        for name, v in zip(msg.names, msg.velocity_rad_s, strict=False):
            out.append((f"robot/joint_velocity/{name}", rr.Scalars(v)))
    elif isinstance(msg, m.JointCommand):
        for name, q in zip(msg.names, msg.position_rad, strict=False):
            out.append((f"robot/joint_command/{name}", rr.Scalars(q)))
    elif isinstance(msg, m.Skeleton):
        if msg.tracked and msg.joints:
            out.append(("world/skeleton/raw", rr.Points3D(
                [j.position_m for j in msg.joints], labels=[j.name for j in msg.joints], radii=0.02)))
    elif isinstance(msg, m.HumanState):
        if msg.tracked:
            out.append(("world/human/hand_corrected", rr.Points3D([msg.hand_position_m], radii=0.03,
                                                                  colors=[(40, 200, 80)])))
            out.append(("world/human/hand_raw", rr.Points3D([msg.hand_raw_position_m], radii=0.02,
                                                            colors=[(200, 60, 60)])))
    elif isinstance(msg, m.ObjectEstimate):
        if msg.found:
            out.append(("world/object/estimate", rr.Boxes3D(centers=[msg.position_m],
                                                            sizes=[msg.size_m])))
    elif isinstance(msg, m.TransferTarget):
        out.append(("world/transfer_target", rr.Points3D([msg.position_base_m], radii=0.03,
                                                         colors=[(250, 200, 0)])))
    elif isinstance(msg, m.SimTruth):
        out.append(("world/truth/object", rr.Points3D([msg.object_position_m], radii=0.025)))
        out.append(("world/truth/receiver_hand", rr.Points3D([msg.receiver_hand_position_m], radii=0.02)))
    elif isinstance(msg, m.DepthImage):
        import numpy as np

        depth = np.frombuffer(msg.depth_mm, dtype="<u2").reshape(msg.height, msg.width)
        out.append(("camera/depth", rr.DepthImage(depth, meter=1000.0)))

    if log_event_text and isinstance(msg, _EVENT_TYPES):
        text = _event_text(msg)
        if text:
            level = rr.TextLogLevel.WARN if isinstance(msg, m.MotionStop) else rr.TextLogLevel.INFO
            out.append(("events", rr.TextLog(text, level=level)))
    return out
