"""Review entities computed from a batch of messages of one key, as columns (no per-row logging).

`derived_columns(topic, messages)` returns, per entity, the Rerun component columns to send with
`rr.send_columns` and the messages (rows) they belong to:

| key | entity | what |
|---|---|---|
| ``robot/joint_state`` | ``robot/joint_position`` | joint positions, rad; a series per joint (`joint_names_style`) |
| ``sim/truth`` | ``world/truth/object``, ``world/truth/receiver_hand``, ``world/tool`` | one point each |
| ``perception/human`` (tracked) | ``world/human/hand_{corrected,raw,correction}`` | points; arrow raw → corrected |
| ``perception/skeleton`` (tracked) | ``world/skeleton/raw``, ``world/skeleton/bones`` | joints (labelled); bones |
| ``perception/object`` (found) | ``world/object/estimate`` | box |
| ``planner/transfer`` | ``world/transfer_target`` | point |
| ``motion/goal`` (Cartesian) | ``world/motion/goal`` | point |
| ``gripper/state`` | ``signals/gripper_mode`` | mode as a number (`GRIPPER_MODE_CODE`) |

All 3-D entities are in the scene's `base` frame (x forward, y left, z up, m); their looks (radius,
colour) are static (`blueprint.static_styles`). Pure apart from building Rerun column objects.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import rerun as rr

from bus_schema import Topic, messages as m
from services.recorder.core import GRIPPER_MODE_CODE, skeleton_bones


@dataclass
class Derived:
    """Columns of one entity; `rows`: indices of the messages they belong to (None: all)."""

    entity: str
    columns: Any
    rows: np.ndarray | None = None


def _points(entity: str, positions_m: Sequence[Sequence[float]], rows: np.ndarray | None = None) -> Derived:
    return Derived(entity, rr.Points3D.columns(positions=np.asarray(positions_m, dtype=np.float32).reshape(-1, 3)),
                   rows)


def _where(flags: Sequence[bool]) -> np.ndarray:
    return np.flatnonzero(np.fromiter(flags, dtype=bool, count=len(flags)))


def _joint_state(msgs: Sequence[m.JointState]) -> list[Derived]:
    lengths = [len(msg.position_rad) for msg in msgs]
    values = np.fromiter((q for msg in msgs for q in msg.position_rad), dtype=np.float64, count=sum(lengths))
    return [Derived("robot/joint_position", rr.Scalars.columns(scalars=values).partition(lengths))]


def _sim_truth(msgs: Sequence[m.SimTruth]) -> list[Derived]:
    return [_points("world/truth/object", [msg.object_position_m for msg in msgs]),
            _points("world/truth/receiver_hand", [msg.receiver_hand_position_m for msg in msgs]),
            _points("world/tool", [msg.tool_position_m for msg in msgs])]


def _human(msgs: Sequence[m.HumanState]) -> list[Derived]:
    rows = _where([msg.tracked for msg in msgs])
    if not rows.size:
        return []
    hand = np.array([msgs[i].hand_position_m for i in rows], dtype=np.float32)
    raw = np.array([msgs[i].hand_raw_position_m for i in rows], dtype=np.float32)
    return [_points("world/human/hand_corrected", hand, rows), _points("world/human/hand_raw", raw, rows),
            Derived("world/human/hand_correction", rr.Arrows3D.columns(origins=raw, vectors=hand - raw), rows)]


def _skeleton(msgs: Sequence[m.Skeleton]) -> list[Derived]:
    rows = _where([msg.tracked and bool(msg.joints) for msg in msgs])
    if not rows.size:
        return []
    joints = [msgs[i].joints for i in rows]
    positions = np.array([j.position_m for js in joints for j in js], dtype=np.float32)
    labels = [j.name for js in joints for j in js]
    bones = [skeleton_bones(js) for js in joints]
    strips = np.array([strip for b in bones for strip in b], dtype=np.float32).reshape(-1, 2, 3)
    return [Derived("world/skeleton/raw", rr.Points3D.columns(positions=positions, labels=labels).partition(
                [len(js) for js in joints]), rows),
            Derived("world/skeleton/bones", rr.LineStrips3D.columns(strips=strips).partition([len(b) for b in bones]),
                    rows)]


def _object(msgs: Sequence[m.ObjectEstimate]) -> list[Derived]:
    rows = _where([msg.found for msg in msgs])
    if not rows.size:
        return []
    centers = np.array([msgs[i].position_m for i in rows], dtype=np.float32)
    half_sizes = np.array([msgs[i].size_m for i in rows], dtype=np.float32) / 2
    return [Derived("world/object/estimate", rr.Boxes3D.columns(centers=centers, half_sizes=half_sizes), rows)]


def _goal(msgs: Sequence[m.MotionGoal]) -> list[Derived]:
    rows = _where([msg.position_base_m is not None for msg in msgs])
    return [_points("world/motion/goal", [msgs[i].position_base_m for i in rows], rows)] if rows.size else []


def _gripper_state(msgs: Sequence[m.GripperState]) -> list[Derived]:
    codes = np.array([GRIPPER_MODE_CODE[msg.mode] for msg in msgs], dtype=np.float64)
    return [Derived("signals/gripper_mode", rr.Scalars.columns(scalars=codes))]


_DERIVE = {
    m.JointState: _joint_state,
    m.SimTruth: _sim_truth,
    m.HumanState: _human,
    m.Skeleton: _skeleton,
    m.ObjectEstimate: _object,
    m.TransferTarget: lambda msgs: [_points("world/transfer_target", [msg.position_base_m for msg in msgs])],
    m.MotionGoal: _goal,
    m.GripperState: _gripper_state,
}


def derived_columns(topic: Topic, msgs: Sequence[m.Message]) -> list[Derived]:
    """The review entities of a batch of `topic`'s messages (empty for keys without any)."""
    derive = _DERIVE.get(topic.type)
    return derive(msgs) if derive is not None and msgs else []


def joint_names_style(names: Sequence[str]) -> rr.SeriesLines:
    """Static legend of ``robot/joint_position``: one series name per joint, in message order."""
    return rr.SeriesLines(names=list(names))
