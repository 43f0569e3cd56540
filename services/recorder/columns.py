"""Batch one-row-per-message data into Arrow record batches for `RecordingStream.send_record_batch`.

Logging one scalar with `rr.log` costs ~20–130 µs (depending on load); a message of the joint
state alone carries ~40 scalars. Instead, rows are buffered per group (one group per bus key)
and turned into one Arrow record batch per group: two index columns (``time``: the sender's
stamp, ``receive_time``: when the recorder received it, both ns since the epoch) and one
column per entity. Rerun splits such a batch into one chunk per entity, so each message is
still logged at its own timestamps. A row that lacks an entity is null there (not logged).

Pure apart from building Arrow arrays: nothing is sent from here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from services.recorder.core import Vec3

TIMELINE_STAMP = "time"
TIMELINE_RECEIVE = "receive_time"

_SCALAR_META = {b"rerun:kind": b"data", b"rerun:archetype": b"rerun.archetypes.Scalars",
                b"rerun:component": b"Scalars:scalars", b"rerun:component_type": b"rerun.components.Scalar"}
_POINT_META = {b"rerun:kind": b"data", b"rerun:archetype": b"rerun.archetypes.Points3D",
               b"rerun:component": b"Points3D:positions", b"rerun:component_type": b"rerun.components.Position3D"}
_POINT_ITEM = pa.list_(pa.field("item", pa.float32(), nullable=False), 3)


def _index_field(name: str) -> pa.Field:
    return pa.field(name, pa.timestamp("ns"), metadata={b"rerun:kind": b"index", b"rerun:index_name": name.encode()})


def _entity_path(entity: str) -> str:
    return entity if entity.startswith("/") else "/" + entity


def _list_of(values: pa.Array, valid: np.ndarray | None) -> pa.Array:
    """Wrap one value per row into a one-element list per row (null where not `valid`)."""
    n_rows = len(values) if valid is None else len(valid)
    if valid is None:
        return pa.ListArray.from_arrays(pa.array(np.arange(n_rows + 1, dtype=np.int32)), values)
    offsets = np.zeros(n_rows + 1, dtype=np.int32)
    np.cumsum(valid, out=offsets[1:])
    return pa.ListArray.from_arrays(pa.array(offsets), values, mask=pa.array(~valid))


@dataclass
class _Group:
    stamps_ns: list[int] = field(default_factory=list)
    receives_ns: list[int] = field(default_factory=list)
    scalars: list[dict[str, float]] = field(default_factory=list)
    points: list[dict[str, Vec3]] = field(default_factory=list)


class ColumnBuffer:
    """Rows waiting to be written, per group and entity set; `take_batches` empties it."""

    def __init__(self) -> None:
        self._groups: dict[tuple[str, ...], _Group] = {}
        self.pending_rows = 0

    def add(self, group: str, stamp_ns: int, receive_ns: int,
            scalars: list[tuple[str, float]], points: list[tuple[str, Vec3]]) -> None:
        """Buffer one message's scalars and 3-D points (`base` frame, m) at its two times."""
        if not scalars and not points:
            return
        # Rows with the same entities share a batch, so that no entity gets null rows.
        key = (group, *(k for k, _ in scalars), "|", *(k for k, _ in points))
        g = self._groups.get(key)
        if g is None:
            g = self._groups[key] = _Group()
        g.stamps_ns.append(stamp_ns)
        g.receives_ns.append(receive_ns)
        g.scalars.append(dict(scalars))
        g.points.append(dict(points))
        self.pending_rows += 1

    def take_batches(self) -> list[pa.RecordBatch]:
        """One record batch per group with everything buffered; the buffer is then empty."""
        batches = [_to_batch(g) for g in self._groups.values() if g.stamps_ns]
        self._groups.clear()
        self.pending_rows = 0
        return batches


def _to_batch(g: _Group) -> pa.RecordBatch:
    fields = [_index_field(TIMELINE_STAMP), _index_field(TIMELINE_RECEIVE)]
    arrays = [pa.array(g.stamps_ns, type=pa.int64()).cast(pa.timestamp("ns")),
              pa.array(g.receives_ns, type=pa.int64()).cast(pa.timestamp("ns"))]
    for entity in dict.fromkeys(k for row in g.scalars for k in row):
        column = [row.get(entity) for row in g.scalars]
        values = pa.array(column, type=pa.float64())
        valid = None
        if values.null_count:
            valid = ~np.asarray(values.is_null().to_numpy(zero_copy_only=False))
            values = values.drop_null()
        path = _entity_path(entity)
        arr = _list_of(values, valid)
        fields.append(pa.field(f"{path}:Scalars:scalars", arr.type, metadata={**_SCALAR_META,
                                                                           b"rerun:entity_path": path.encode()}))
        arrays.append(arr)
    for entity in dict.fromkeys(k for row in g.points for k in row):
        present = [row.get(entity) for row in g.points]
        valid = np.array([p is not None for p in present])
        xyz = np.array([p for p in present if p is not None], dtype=np.float32).reshape(-1)
        values = pa.FixedSizeListArray.from_arrays(pa.array(xyz, type=pa.float32()), type=_POINT_ITEM)
        path = _entity_path(entity)
        arr = _list_of(values, None if valid.all() else valid)
        fields.append(pa.field(f"{path}:Points3D:positions", arr.type, metadata={**_POINT_META,
                                                                              b"rerun:entity_path": path.encode()}))
        arrays.append(arr)
    return pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields))
