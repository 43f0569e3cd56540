"""ROS 1 messages through rosbags' type store: definitions, MD5 sums, wire bytes.

`STORE` is rosbags' ROS 1 Noetic type store: it already holds the standard types
(std_msgs, sensor_msgs, geometry_msgs); the other types' ``.msg`` texts (Baxter's
baxter_core_msgs, this project's handover_msgs) are registered into it by `message_class`.
rosbags parses the definitions, computes the genmsg MD5 sums and full definitions, and
writes and reads the ROS 1 wire format; no ROS installation is required.

The message classes are this package's frozen dataclasses (tuples for arrays, `bytes` for
``uint8[]``/``char[]`` arrays such as an image's data, `Time` for ``time``), converted field by
field to and from rosbags' generated classes (numpy arrays, ``builtin_interfaces/msg/Time``).
ROS names are ``pkg/Type``; the store's are ``pkg/msg/Type``.

Decoding never trusts the input: any bytes that are not exactly one message of the type
raise `Ros1DecodeError`, one line naming the type; a value that cannot be written raises
`Ros1EncodeError`.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, fields, is_dataclass
from typing import Any, ClassVar

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore
from rosbags.typesys.msg import normalize_msgtype

from services.bridge.baxter.errors import BaxterError

STORE = get_typestore(Stores.ROS1_NOETIC)
_TIME = "builtin_interfaces/msg/Time"
#: Array element types carried as `bytes` (ROS 1 ``char`` is an unsigned byte too).
_BYTE_TYPES = ("uint8", "char")


class Ros1Error(BaxterError):
    """Root of the ROS 1 message errors (an unknown type or a definition that does not parse)."""


class Ros1DecodeError(Ros1Error):
    """Bytes that are not a valid message of the expected type (the message says why)."""


class Ros1EncodeError(Ros1Error):
    """A value that cannot be written as the declared field type (the message says which)."""


@dataclass(frozen=True)
class Time:
    """ROS 1 ``time``: unsigned seconds and nanoseconds since the Unix epoch."""

    secs: int = 0
    nsecs: int = 0

    @classmethod
    def from_ns(cls, stamp_ns: int) -> Time:
        return cls(int(stamp_ns // 1_000_000_000), int(stamp_ns % 1_000_000_000))

    def to_ns(self) -> int:
        return self.secs * 1_000_000_000 + self.nsecs


def _store_name(type_name: str) -> str:
    if type_name not in _CLASSES:
        raise Ros1Error(f"ROS 1 message type {type_name!r} is not registered")
    return normalize_msgtype(type_name)


def md5sum(type_name: str) -> str:
    """The type's MD5 sum, hex (as in ``rosmsg md5``)."""
    return STORE.generate_msgdef(_store_name(type_name))[1]


def full_definition(type_name: str) -> str:
    """The ``message_definition`` of a connection header (the type, then each dependency
    after a line of 80 ``=`` and ``MSG: pkg/Type``; comments dropped)."""
    return STORE.generate_msgdef(_store_name(type_name))[0]


# ------------------------------------------------------------- our dataclasses ↔ rosbags'


def _to_store(value: Any, desc: Any) -> Any:
    kind, arg = desc
    if kind == Nodetype.BASE:
        return value
    if kind == Nodetype.NAME:
        if arg == _TIME:  # the store's Time has an int32 sec; ROS 1's is uint32, same bytes
            if not 0 <= value.secs < 1 << 32:
                raise ValueError(f"time secs {value.secs} is not a uint32")
            return STORE.types[_TIME](value.secs - (1 << 32 if value.secs >= 1 << 31 else 0), value.nsecs)
        msgdef = STORE.get_msgdef(arg)
        return msgdef.cls(*(_to_store(getattr(value, name), d) for name, d in msgdef.fields))
    element = arg[0]
    if element[0] == Nodetype.BASE and element[1][0] in _BYTE_TYPES:
        return np.frombuffer(bytes(value), dtype=np.uint8)
    if element[0] == Nodetype.BASE and element[1][0] != "string":
        return np.asarray(value, dtype=element[1][0])
    return [_to_store(item, element) for item in value]


def _from_store(value: Any, desc: Any) -> Any:
    kind, arg = desc
    if kind == Nodetype.BASE:
        return value
    if kind == Nodetype.NAME:
        if arg == _TIME:
            return Time(value.sec & 0xFFFF_FFFF, value.nanosec)
        return _CLASSES[arg](*(_from_store(getattr(value, name), d)
                               for name, d in STORE.get_msgdef(arg).fields))
    if isinstance(value, np.ndarray):
        if value.dtype == np.uint8 and arg[0][0] == Nodetype.BASE and arg[0][1][0] in _BYTE_TYPES:
            return value.tobytes()  # one copy: an image's data stays a buffer, not a tuple of ints
        return tuple(value.tolist())
    return tuple(_from_store(item, arg[0]) for item in value)


class Ros1Message:
    """Base of the message classes: frozen dataclasses whose fields follow `TYPE`'s
    definition, in order, with the same names."""

    TYPE: ClassVar[str]

    def to_bytes(self) -> bytes:
        """The message's ROS 1 serialisation."""
        name = normalize_msgtype(self.TYPE)
        try:
            return bytes(STORE.serialize_ros1(_to_store(self, (Nodetype.NAME, name)), name))
        except (SerdeError, struct.error, AttributeError, TypeError, ValueError, OverflowError) as exc:
            raise Ros1EncodeError(f"{self.TYPE}: {exc}") from None

    @classmethod
    def from_bytes(cls, data: bytes | bytearray | memoryview) -> Any:
        """Deserialise; the whole buffer must be one message.

        Raises:
            Ros1DecodeError: truncated, over-long or malformed bytes.
        """
        name = normalize_msgtype(cls.TYPE)
        try:
            return _from_store(STORE.deserialize_ros1(bytes(data), name), (Nodetype.NAME, name))
        except SerdeError as exc:
            raise Ros1DecodeError(f"{cls.TYPE}: {exc}") from None

    @classmethod
    def md5sum(cls) -> str:
        return md5sum(cls.TYPE)

    @classmethod
    def full_definition(cls) -> str:
        return full_definition(cls.TYPE)


_CLASSES: dict[str, type] = {}  # by ROS name and by store name


def message_class(type_name: str, text: str | None = None):
    """Class decorator: bind the dataclass to ROS 1 type `type_name` (``pkg/Type``).

    `text` is the ``.msg`` definition, registered into `STORE`; None for a type the store
    already holds. Checks that the dataclass fields match the definition's, name for name.
    """
    name = normalize_msgtype(type_name)

    def bind(cls: type) -> type:
        try:
            if text is not None:
                STORE.register(get_types_from_msg(text, name))
            wanted = tuple(field for field, _ in STORE.fielddefs[name][1])
        except (TypesysError, KeyError) as exc:
            raise Ros1Error(f"{type_name}: cannot register its definition: {exc}") from None
        if not is_dataclass(cls):
            raise Ros1Error(f"{cls.__name__} must be a dataclass")
        names = tuple(f.name for f in fields(cls))
        if names != wanted:
            raise Ros1Error(f"{cls.__name__} fields {names} do not match {type_name} {wanted}")
        cls.TYPE = type_name  # type: ignore[attr-defined]
        _CLASSES[type_name] = _CLASSES[name] = cls
        return cls

    return bind
