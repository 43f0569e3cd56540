"""Read a recording back with the Rerun SDK (for `handover-recorder inspect` and tests).

The recorder writes its files without Rerun's footer (see `writer`): they are read in one pass
with `RrdReader.stream()`; Rerun's warning about the missing footer is expected and silenced.
"""

from __future__ import annotations

import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
import pyarrow as pa
import rerun.chunk as rrc

from services.recorder.errors import RecorderError


def _reader(path: Path) -> rrc.RrdReader:
    if not Path(path).is_file():
        raise RecorderError(f"recording {path} does not exist")
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="RRD file has no footer")
            return rrc.RrdReader(str(path))
    except Exception as exc:
        raise RecorderError(f"{path} is not a readable Rerun recording: {exc}") from None


def entity_row_counts(path: Path, include_static: bool = True) -> dict[str, int]:
    """Rows logged per entity path (temporal, and static ones unless `include_static` is False)."""
    counts: dict[str, int] = defaultdict(int)
    for chunk in _reader(path).stream():
        if include_static or not chunk.is_static:
            counts[chunk.entity_path] += chunk.num_rows
    return dict(sorted(counts.items()))


def read_scalars(path: Path, entity_prefix: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Scalar series under `entity_prefix`: {entity: (time_ns, value)}, sorted by time.

    `time_ns` is the ``time`` timeline (the sender's stamp of each message).
    """
    prefix = entity_prefix if entity_prefix.startswith("/") else "/" + entity_prefix
    series: dict[str, list[tuple[int, float]]] = defaultdict(list)
    for chunk in _reader(path).stream():
        if not chunk.entity_path.startswith(prefix) or chunk.is_static:
            continue
        batch = chunk.to_record_batch()
        names = batch.schema.names
        if "time" not in names:
            continue
        scalar_cols = [n for n in names if n.endswith("Scalars:scalars")]
        if not scalar_cols:
            continue
        times = batch.column("time").cast(pa.int64()).to_numpy(zero_copy_only=False)
        values = batch.column(scalar_cols[0]).to_pylist()
        for t, v in zip(times, values, strict=True):
            if v:
                series[chunk.entity_path].append((int(t), float(v[0])))
    out = {}
    for entity, rows in series.items():
        rows.sort()
        out[entity] = (np.array([t for t, _ in rows], dtype=np.int64),
                       np.array([v for _, v in rows], dtype=float))
    return out


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
