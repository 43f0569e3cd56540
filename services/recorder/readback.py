"""Read a recording back with the Rerun SDK (for `handover-recorder inspect` and tests).

Files are read in one pass with `RrdReader.stream()`, with or without Rerun's footer (the
recorder adds it when it closes the file, `finalise`; a killed recorder's file has none: Rerun's
warning about that is expected and silenced).
`read_scalars` names the series of the ``bus/<key>`` entities (one component per message field,
`bus_columns`) ``/bus/<key>/<field>[/<index>]``, as the recorder's earlier one-entity-per-number
layout did.
"""

from __future__ import annotations

import functools
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import rerun.chunk as rrc

from bus_schema import TOPICS
from services.recorder.bus_columns import field_plans
from services.recorder.errors import RecorderError

_BUS_TYPE_NAMES = frozenset(t.type.__name__ for t in TOPICS)


def _reader(path: Path) -> rrc.RrdReader:
    if not Path(path).is_file():
        raise RecorderError(f"recording {path} does not exist")
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="RRD file has no footer")
            return rrc.RrdReader(str(path))
    except Exception as exc:  # noqa: BLE001 - whatever Rerun's reader raises becomes a RecorderError
        raise RecorderError(f"{path} is not a readable Rerun recording: {exc}") from None


def entity_row_counts(path: Path, include_static: bool = True) -> dict[str, int]:
    """Rows logged per entity path (temporal, and static ones unless `include_static` is False)."""
    counts: dict[str, int] = defaultdict(int)
    for chunk in _reader(path).stream():
        if include_static or not chunk.is_static:
            counts[chunk.entity_path] += chunk.num_rows
    return dict(sorted(counts.items()))


def _numeric_values(column: pa.Array) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(row index, instance index, value as float) of every number in a component column (a list
    per row or one value per row); None when the column is not numeric."""
    if pa.types.is_list(column.type) or pa.types.is_large_list(column.type):
        if not _is_number(column.type.value_type):
            return None
        rows = np.asarray(pc.list_parent_indices(column), dtype=np.int64)
        offsets = np.asarray(column.offsets, dtype=np.int64)
        instances = np.arange(rows.size, dtype=np.int64) - (offsets[rows] - offsets[0])
        values = pc.list_flatten(column)
    elif _is_number(column.type):
        valid = np.asarray(column.is_valid(), dtype=bool)
        rows = np.flatnonzero(valid)
        instances = np.zeros(rows.size, dtype=np.int64)
        values = column.filter(pa.array(valid))
    else:
        return None
    return rows, instances, np.asarray(values.cast(pa.float64()), dtype=float)


def _is_number(t: pa.DataType) -> bool:
    return pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t)


@functools.cache
def _bus_sequence_fields() -> frozenset[str]:
    """Components ``<MessageType>:<field>`` of `bus_columns` whose field is a tuple or list (its
    series get an index), as opposed to one number per message."""
    return frozenset(p.component for t in TOPICS for p in field_plans(t.type) if pa.types.is_list(p.arrow_type))


def read_scalars(path: Path, prefix: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Numeric series whose path starts with `prefix`: {series: (time_ns, value)}, sorted by time.

    Series paths:
    - a `Scalars` entity: its path (one value per row), or ``<entity>/<name>`` per instance
      when it has several (names from its static `SeriesLines`, else the index), e.g.
      ``/robot/joint_position/right_s0``;
    - a field of a ``bus/<key>`` entity (`bus_columns`): ``/bus/<key>/<field>``, and
      ``/bus/<key>/<field>/<i>`` for the elements of tuples and lists, e.g.
      ``/bus/sensors/wrist_wrench/force_n/0`` (bools count 0/1).

    `time_ns` is the ``time`` timeline (the sender's stamp of each message).
    """
    prefix = prefix if prefix.startswith("/") else "/" + prefix
    parts: dict[tuple[str, int | None], list[tuple[np.ndarray, np.ndarray]]] = defaultdict(list)
    names: dict[str, list[str]] = {}
    for chunk in _reader(path).stream():
        entity = chunk.entity_path
        if not (entity.startswith(prefix) or prefix.startswith(entity + "/")):
            continue
        batch = chunk.to_record_batch()
        if chunk.is_static:
            if "SeriesLines:names" in batch.schema.names:
                names[entity] = [n for v in batch.column("SeriesLines:names").to_pylist() if v for n in v]
            continue
        if "time" not in batch.schema.names:
            continue
        times = np.asarray(batch.column("time").cast(pa.int64()), dtype=np.int64)
        for field, column in zip(batch.schema, batch.columns, strict=True):
            component = (field.metadata or {}).get(b"rerun:component", b"").decode()
            if component == "Scalars:scalars":
                base, indexed = entity, True  # named at the end
            elif entity.startswith("/bus/") and component.split(":", 1)[0] in _BUS_TYPE_NAMES:
                base, indexed = f"{entity}/{component.split(':', 1)[1]}", component in _bus_sequence_fields()
            else:
                continue
            numbers = _numeric_values(column)
            if numbers is None:
                continue
            rows, instances, values = numbers
            for i in np.unique(instances):
                pick = instances == i
                parts[(base, int(i) if indexed else None)].append((times[rows[pick]], values[pick]))
    out = {}
    for (base, i), pieces in parts.items():
        series = base if i is None else _instance_path(base, i, names.get(base), parts)
        if series != prefix and not series.startswith(prefix.rstrip("/") + "/"):
            continue
        times = np.concatenate([t for t, _ in pieces])
        values = np.concatenate([v for _, v in pieces])
        order = np.lexsort((values, times))
        out[series] = (times[order], values[order])
    return out


def _instance_path(base: str, i: int, names: list[str] | None, parts) -> str:
    """Series path of instance `i`: ``<base>/<name>`` (named `Scalars`), ``<base>`` (a `Scalars`
    entity with one value per row), else ``<base>/<i>``."""
    if not base.startswith("/bus/") and all(j == 0 for (b, j) in parts if b == base):
        return base
    if names and i < len(names):
        return f"{base}/{names[i]}"
    return f"{base}/{i}"


def read_text_log(path: Path, entity: str = "/events") -> list[str]:
    """Text log lines at `entity`, in time order."""
    rows: list[tuple[int, str]] = []
    for chunk in _reader(path).stream():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        text_cols = [n for n in batch.schema.names if n.endswith("TextLog:text")]
        if not text_cols or "time" not in batch.schema.names:
            continue
        times = batch.column("time").cast(pa.int64()).to_pylist()
        for t, text in zip(times, batch.column(text_cols[0]).to_pylist(), strict=True):
            rows.append((t, text[0] if isinstance(text, list) else text))
    rows.sort()
    return [text for _, text in rows]


def read_component(path: Path, entity: str, component: str) -> list[tuple[int, object]]:
    """(time_ns, value) rows of one component (e.g. ``Points3D:positions``) of `entity`, sorted
    by the ``time`` timeline; values as Python lists (positions in the `base` frame, m)."""
    entity = entity if entity.startswith("/") else "/" + entity
    rows: list[tuple[int, object]] = []
    for chunk in _reader(path).stream():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if n.endswith(component)]
        if not names or "time" not in batch.schema.names:
            continue
        times = batch.column("time").cast(pa.int64()).to_pylist()
        rows += [(t, v) for t, v in zip(times, batch.column(names[0]).to_pylist(), strict=True) if v is not None]
    rows.sort(key=lambda r: r[0])
    return rows


def read_static_component(path: Path, entity: str, component: str) -> list[object]:
    """Values of one static component (e.g. ``CoordinateFrame:frame``) of `entity`, in file order."""
    entity = entity if entity.startswith("/") else "/" + entity
    values: list[object] = []
    for chunk in _reader(path).stream():
        if chunk.entity_path != entity or not chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = [n for n in batch.schema.names if n.endswith(component)]
        if names:
            values += [v for v in batch.column(names[0]).to_pylist() if v is not None]
    return values


def read_times(path: Path, entity: str) -> tuple[np.ndarray, np.ndarray]:
    """(``time``, ``receive_time``) in ns of every row of `entity`, sorted by ``time``: the
    sender's stamp and when the bus received the message (their difference: the bus latency)."""
    entity = entity if entity.startswith("/") else "/" + entity
    stamps: list[np.ndarray] = []
    receives: list[np.ndarray] = []
    for chunk in _reader(path).stream():
        if chunk.entity_path != entity or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        if {"time", "receive_time"} <= set(batch.schema.names):
            stamps.append(np.asarray(batch.column("time").cast(pa.int64()), dtype=np.int64))
            receives.append(np.asarray(batch.column("receive_time").cast(pa.int64()), dtype=np.int64))
    if not stamps:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    t, r = np.concatenate(stamps), np.concatenate(receives)
    order = np.argsort(t, kind="stable")
    return t[order], r[order]
