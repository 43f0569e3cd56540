"""Every bus message, whole, as one row of one entity per key: ``bus/<key suffix>``.

A batch of messages of one key becomes one Arrow record batch, i.e. one Rerun chunk: two index
columns (``time``: the sender's `stamp_ns`; ``receive_time``: when the recorder's Zenoh callback
got it; ns since the epoch) and one component column per message field, named
``<MessageType>:<field>`` (e.g. ``WristWrench:force_n`` at ``/bus/sensors/wrist_wrench``):

- numbers and bools: one value per row (float64, int64, bool);
- tuples and lists of numbers: one instance per element (``force_n``: 3 per row), so a time
  series view draws one line per element;
- strings, and lists of strings: as they are (``source``, ``mode``, joint ``names``);
- nested messages as Arrow structs, tables as maps (the skeleton's joint list: a list of
  {name, position_m, confidence}; the episode summary's phase durations: a string → float map);
- `stamp_ns` is the ``time`` index; bytes (the depth image) are left out (see `writer`).

One entity per key rather than one per field (the recorder's earlier layout): the two time
columns and the row ids are stored once per key instead of once per field, ~40 chunks per
flush instead of ~170. Time series views plot these components through component mappings
(`blueprint`); `readback.read_scalars` names the series ``/bus/<key>/<field>[/<index>]``.

Pure: builds Arrow arrays, sends nothing. The columns are made with C-level conversions
(`operator.attrgetter` over the messages, `pyarrow.array` with the planned type): no Python
work per field per message.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np
import pyarrow as pa

from bus_schema import Topic
from services.recorder.columns import INDEX_FIELDS, time_arrays

#: Header field that is the ``time`` index, not a component.
_INDEX_FIELD = "stamp_ns"

_STRING_TYPES = (msgspec.inspect.StrType, msgspec.inspect.LiteralType)


@dataclass(frozen=True)
class FieldPlan:
    """How one message field is stored: its component and Arrow type; `nested`: its values are
    converted to builtins (dicts, lists) first (structs, lists of structs, tables)."""

    name: str
    component: str
    arrow_type: pa.DataType
    nested: bool = False


def _unwrap(t: Any) -> tuple[Any, bool]:
    """(type without Metadata and ``| None``, nullable)."""
    while isinstance(t, msgspec.inspect.Metadata):
        t = t.type
    if isinstance(t, msgspec.inspect.UnionType):
        kinds = [k for k in t.types if not isinstance(k, msgspec.inspect.NoneType)]
        if len(kinds) == 1:
            return _unwrap(kinds[0])[0], True
    return t, False


def _scalar_arrow_type(t: Any) -> pa.DataType | None:
    t, _ = _unwrap(t)
    if isinstance(t, msgspec.inspect.BoolType):
        return pa.bool_()
    if isinstance(t, msgspec.inspect.IntType):
        return pa.int64()
    if isinstance(t, msgspec.inspect.FloatType):
        return pa.float64()
    if isinstance(t, _STRING_TYPES):
        return pa.string()
    return None


def _arrow_type(t: Any) -> pa.DataType:
    """The Arrow type of a field of msgspec type `t` (recursively for structs, lists, tables)."""
    t, _ = _unwrap(t)
    scalar = _scalar_arrow_type(t)
    if scalar is not None:
        return scalar
    if isinstance(t, msgspec.inspect.TupleType):
        items = {_arrow_type(i) for i in t.item_types}
        if items <= {pa.int64(), pa.float64()}:
            return pa.list_(pa.float64() if pa.float64() in items else pa.int64())
        if len(items) == 1:
            return pa.list_(items.pop())
    if isinstance(t, (msgspec.inspect.ListType, msgspec.inspect.VarTupleType, msgspec.inspect.SetType)):
        return pa.list_(_arrow_type(t.item_type))
    if isinstance(t, msgspec.inspect.StructType):
        return pa.struct([(f.name, _arrow_type(f.type)) for f in t.fields])
    if isinstance(t, msgspec.inspect.DictType):
        return pa.map_(_arrow_type(t.key_type), _arrow_type(t.value_type))
    raise TypeError(f"no Arrow type for {t!r}: extend bus_columns._arrow_type")


def _nested(arrow_type: pa.DataType) -> bool:
    """True when values must be converted to builtins before `pyarrow.array`."""
    if pa.types.is_struct(arrow_type) or pa.types.is_map(arrow_type):
        return True
    return pa.types.is_list(arrow_type) and _nested(arrow_type.value_type)


@functools.cache
def field_plans(message_type: type[msgspec.Struct]) -> tuple[FieldPlan, ...]:
    """The stored fields of `message_type`, in declaration order."""
    plans = []
    prefix = message_type.__name__
    for f in msgspec.inspect.type_info(message_type).fields:
        if f.name == _INDEX_FIELD or isinstance(_unwrap(f.type)[0], msgspec.inspect.BytesType):
            continue
        arrow_type = _arrow_type(f.type)
        plans.append(FieldPlan(f.name, f"{prefix}:{f.name}", arrow_type, _nested(arrow_type)))
    return tuple(plans)


def numeric_series(plan: FieldPlan) -> bool:
    """True when the field is plotted as time series (numbers, bools, lists of numbers)."""
    t = plan.arrow_type
    if pa.types.is_list(t):
        t = t.value_type
    return pa.types.is_floating(t) or pa.types.is_integer(t) or pa.types.is_boolean(t)


def _column(plan: FieldPlan, values: Sequence[Any]) -> pa.Array:
    return pa.array(msgspec.to_builtins(values) if plan.nested else values, type=plan.arrow_type)


@functools.cache
def _getter(message_type: type[msgspec.Struct]) -> Callable[[Any], tuple[Any, ...]]:
    names = [p.name for p in field_plans(message_type)]
    getter = operator.attrgetter(*names)
    return getter if len(names) > 1 else (lambda msg: (getter(msg),))


def bus_entity(topic: Topic) -> str:
    """Entity path of a key's messages (``/bus/<suffix>``)."""
    return f"/bus/{topic.suffix}"


def bus_record_batch(topic: Topic, messages: Sequence[msgspec.Struct], stamps_ns: np.ndarray,
                     receives_ns: np.ndarray) -> pa.RecordBatch:
    """One row per message of `topic` (all of its `topic.type`), at the given times."""
    plans = field_plans(topic.type)
    rows = list(map(_getter(topic.type), messages))
    columns = list(zip(*rows, strict=True)) if rows else [() for _ in plans]
    arrays = [*time_arrays(stamps_ns, receives_ns), *(_column(p, v) for p, v in zip(plans, columns, strict=True))]
    return pa.RecordBatch.from_arrays(arrays, schema=_schema(topic))


@functools.cache
def _schema(topic: Topic) -> pa.Schema:
    entity = bus_entity(topic)
    archetype = topic.type.__name__.encode()
    return pa.schema([*INDEX_FIELDS, *(pa.field(f"{entity}:{p.component}", p.arrow_type, metadata={
        b"rerun:kind": b"data", b"rerun:entity_path": entity.encode(), b"rerun:archetype": archetype,
        b"rerun:component": p.component.encode()}) for p in field_plans(topic.type))])
