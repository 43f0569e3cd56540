"""ROS 1 wire format: serialisation, message definitions and MD5 sums (genmsg rules).

Only what the Baxter backend needs; no ROS installation is required.

Wire format (ROS 1 "serialization" spec, little-endian, no padding, no alignment):

- ``bool``/``uint8``/``int8`` (and the legacy ``byte``/``char``): 1 byte; ``(u)int16`` 2,
  ``(u)int32`` 4, ``(u)int64`` 8, ``float32`` 4, ``float64`` 8 (IEEE 754);
- ``string``: uint32 byte length, then the bytes (UTF-8 here), no terminator;
- ``time``: uint32 secs, uint32 nsecs; ``duration``: int32 secs, int32 nsecs;
- variable-length array ``T[]``: uint32 element count, then the elements;
  fixed-length array ``T[N]``: the N elements, no count;
- a nested message: its fields in order, no framing.

MD5 sum (genmsg ``compute_md5_text``): the text made of the constants first
(``type NAME=value``, one a line) then the fields (``type name``), where the type of a
field whose type is a message is replaced by that message's MD5 sum (array suffix dropped);
comments and blank lines removed; the lines joined by ``\\n`` with no trailing newline; the
MD5 of that text. The full definition (connection header ``message_definition``) is the
message's own text followed, for each message type it depends on, by a line of 80 ``=``,
``MSG: pkg/Type`` and that message's text.

Decoding never trusts the input: a length that runs past the end of the buffer, bytes left
over, an invalid UTF-8 string, or a bool that is not 0/1 raise `Ros1DecodeError` with the
field path; nothing else escapes.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass, fields, is_dataclass
from typing import Any, ClassVar

#: Primitive types → struct format (little-endian). ``byte`` and ``char`` are the legacy
#: aliases of ``int8`` and ``uint8``.
PRIMITIVE_FORMATS: dict[str, str] = {
    "bool": "<B", "int8": "<b", "uint8": "<B", "byte": "<b", "char": "<B",
    "int16": "<h", "uint16": "<H", "int32": "<i", "uint32": "<I",
    "int64": "<q", "uint64": "<Q", "float32": "<f", "float64": "<d",
}
BUILTIN_TYPES = frozenset(PRIMITIVE_FORMATS) | {"string", "time", "duration"}

#: Decoding refuses arrays and strings declaring more than this many elements/bytes
#: (the bus carries at most 1 MiB per message anyway).
MAX_DECLARED_LENGTH = 1 << 20


class Ros1Error(Exception):
    """Root of the ROS 1 serialisation errors."""


class Ros1DecodeError(Ros1Error):
    """Bytes that are not a valid message of the expected type (the message says where)."""


class Ros1EncodeError(Ros1Error):
    """A value that cannot be written as the declared field type (the message says which)."""


# --------------------------------------------------------------------------- definitions


@dataclass(frozen=True)
class FieldSpec:
    """One field: its declared type (``float64[]``, ``Header``, ``string``) and name."""

    type: str
    name: str

    @property
    def base_type(self) -> str:
        """The element type without array brackets (``float64`` for ``float64[3]``)."""
        return self.type.split("[", 1)[0]

    @property
    def array_length(self) -> int | None:
        """None for a scalar, -1 for ``T[]``, N for ``T[N]``."""
        if "[" not in self.type:
            return None
        inside = self.type[self.type.index("[") + 1 : -1]
        return -1 if inside == "" else int(inside)


@dataclass(frozen=True)
class ConstantSpec:
    """A constant: ``type NAME=value`` (value kept as the text after '=' stripped)."""

    type: str
    name: str
    value_text: str


@dataclass(frozen=True)
class MsgSpec:
    """A parsed ``.msg`` definition.

    Attributes:
        type_name: ``pkg/Type``.
        text: the ``.msg`` text as in the package (comments included).
        fields: the fields in wire order.
        constants: the constants in declaration order.
    """

    type_name: str
    text: str
    fields: tuple[FieldSpec, ...]
    constants: tuple[ConstantSpec, ...]

    @property
    def package(self) -> str:
        return self.type_name.split("/", 1)[0]


def _resolve(type_name: str, package: str) -> str:
    """Full ``pkg/Type`` of a field's message type, as genmsg resolves it."""
    if type_name == "Header":
        return "std_msgs/Header"
    if "/" in type_name:
        return type_name
    return f"{package}/{type_name}"


def parse_definition(type_name: str, text: str) -> MsgSpec:
    """Parse a ``.msg`` text with genmsg's rules (comments after ``#``; string constants
    take everything after ``=`` with no comment).

    Raises:
        Ros1Error: a line that is neither a field, a constant, a comment nor blank.
    """
    package = type_name.split("/", 1)[0]
    field_specs: list[FieldSpec] = []
    constants: list[ConstantSpec] = []
    for line_no, raw in enumerate(text.splitlines(), 1):
        stripped = raw.strip()
        if not stripped or stripped.startswith("#"):
            continue
        clean = stripped.split("#", 1)[0].strip()
        first, _, rest = stripped.partition(" ")
        if "=" in clean:  # a constant (genmsg decides on the comment-free line)
            source = rest if first == "string" else clean[len(first):]
            name, _, value = source.partition("=")
            constants.append(ConstantSpec(first, name.strip(), value.strip()))
            continue
        parts = clean.split()
        if len(parts) != 2:
            raise Ros1Error(f"{type_name}.msg line {line_no}: cannot parse {raw!r}")
        ftype, fname = parts
        base = ftype.split("[", 1)[0]
        if base not in BUILTIN_TYPES:
            ftype = _resolve(base, package) + ftype[len(base):]
        field_specs.append(FieldSpec(ftype, fname))
    return MsgSpec(type_name, text, tuple(field_specs), tuple(constants))


_SPECS: dict[str, MsgSpec] = {}


def register(type_name: str, text: str) -> MsgSpec:
    """Parse and register a definition (dependencies must be registered before use)."""
    spec = parse_definition(type_name, text)
    _SPECS[type_name] = spec
    return spec


def spec_of(type_name: str) -> MsgSpec:
    try:
        return _SPECS[type_name]
    except KeyError:
        raise Ros1Error(f"ROS 1 message type {type_name!r} is not registered") from None


def md5_text(type_name: str) -> str:
    """The text whose MD5 is the type's MD5 sum (genmsg ``compute_md5_text``)."""
    spec = spec_of(type_name)
    lines = [f"{c.type} {c.name}={c.value_text}" for c in spec.constants]
    for f in spec.fields:
        if f.base_type in BUILTIN_TYPES:
            lines.append(f"{f.type} {f.name}")
        else:
            lines.append(f"{md5sum(f.base_type)} {f.name}")
    return "\n".join(lines)


def md5sum(type_name: str) -> str:
    """The type's MD5 sum, hex (as in ``rosmsg md5``)."""
    return hashlib.md5(md5_text(type_name).encode()).hexdigest()


def _dependencies(type_name: str, seen: list[str]) -> list[str]:
    for f in spec_of(type_name).fields:
        if f.base_type not in BUILTIN_TYPES and f.base_type not in seen:
            seen.append(f.base_type)
            _dependencies(f.base_type, seen)
    return seen


def full_definition(type_name: str) -> str:
    """The ``message_definition`` of a connection header (gendeps ``--cat`` layout)."""
    parts = [spec_of(type_name).text.rstrip("\n") + "\n"]
    for dep in _dependencies(type_name, []):
        parts.append("=" * 80 + "\n" + f"MSG: {dep}\n" + spec_of(dep).text.rstrip("\n") + "\n")
    return "".join(parts)


# --------------------------------------------------------------------------- messages


class Ros1Message:
    """Base of the message classes: frozen dataclasses whose fields follow `TYPE`'s
    definition, in order, with the same names."""

    TYPE: ClassVar[str]

    def to_bytes(self) -> bytes:
        """Serialise (see module docstring)."""
        out = bytearray()
        _write_struct(out, self.TYPE, self, self.TYPE)
        return bytes(out)

    @classmethod
    def from_bytes(cls, data: bytes | bytearray | memoryview) -> Any:
        """Deserialise; the whole buffer must be one message.

        Raises:
            Ros1DecodeError: truncated, over-long or malformed bytes (says which field).
        """
        reader = _Reader(bytes(data))
        value = _read_struct(reader, cls.TYPE, cls.TYPE)
        if reader.remaining:
            raise Ros1DecodeError(
                f"{cls.TYPE}: {reader.remaining} byte(s) left after the last field"
            )
        return value

    @classmethod
    def md5sum(cls) -> str:
        return md5sum(cls.TYPE)

    @classmethod
    def full_definition(cls) -> str:
        return full_definition(cls.TYPE)


_CLASSES: dict[str, type] = {}


def message_class(type_name: str, text: str):
    """Class decorator: register the definition and bind the dataclass to it.

    Checks that the dataclass fields match the definition's fields, name for name.
    """

    def bind(cls: type) -> type:
        spec = register(type_name, text)
        if not is_dataclass(cls):
            raise Ros1Error(f"{cls.__name__} must be a dataclass")
        names = tuple(f.name for f in fields(cls))
        wanted = tuple(f.name for f in spec.fields)
        if names != wanted:
            raise Ros1Error(f"{cls.__name__} fields {names} do not match {type_name} {wanted}")
        cls.TYPE = type_name  # type: ignore[attr-defined]
        _CLASSES[type_name] = cls
        return cls

    return bind


# --------------------------------------------------------------------------- writing


def _write_primitive(out: bytearray, ftype: str, value: Any, path: str) -> None:
    if ftype == "string":
        if isinstance(value, str):
            raw = value.encode("utf-8")
        elif isinstance(value, (bytes, bytearray)):
            raw = bytes(value)
        else:
            raise Ros1EncodeError(f"{path}: expected a string, got {type(value).__name__}")
        out += struct.pack("<I", len(raw))
        out += raw
        return
    if ftype in ("time", "duration"):
        fmt = "<II" if ftype == "time" else "<ii"
        try:
            out += struct.pack(fmt, int(value.secs), int(value.nsecs))
        except (AttributeError, struct.error, TypeError, ValueError) as exc:
            raise Ros1EncodeError(f"{path}: bad {ftype} {value!r}: {exc}") from None
        return
    fmt = PRIMITIVE_FORMATS[ftype]
    try:
        if ftype == "bool":
            value = 1 if value else 0
        elif fmt[-1] in "fd":
            value = float(value)
        else:
            if isinstance(value, float) and not value.is_integer():
                raise Ros1EncodeError(f"{path}: {ftype} cannot hold {value!r}")
            value = int(value)
        out += struct.pack(fmt, value)
    except struct.error as exc:
        raise Ros1EncodeError(f"{path}: {value!r} does not fit {ftype}: {exc}") from None


def _write_value(out: bytearray, spec: FieldSpec, value: Any, path: str) -> None:
    base, length = spec.base_type, spec.array_length
    if length is None:
        if base in BUILTIN_TYPES:
            _write_primitive(out, base, value, path)
        else:
            _write_struct(out, base, value, path)
        return
    if base in ("uint8", "char") and isinstance(value, (bytes, bytearray)):
        items: Any = bytes(value)
    else:
        try:
            items = list(value)
        except TypeError:
            raise Ros1EncodeError(f"{path}: expected a sequence for {spec.type}") from None
    if length == -1:
        out += struct.pack("<I", len(items))
    elif len(items) != length:
        raise Ros1EncodeError(f"{path}: {spec.type} needs {length} elements, got {len(items)}")
    if isinstance(items, bytes):
        out += items
        return
    element = FieldSpec(base, spec.name)
    for i, item in enumerate(items):
        _write_value(out, element, item, f"{path}[{i}]")


def _write_struct(out: bytearray, type_name: str, value: Any, path: str) -> None:
    for f in spec_of(type_name).fields:
        try:
            item = getattr(value, f.name)
        except AttributeError:
            raise Ros1EncodeError(f"{path}: missing field {f.name!r} of {type_name}") from None
        _write_value(out, f, item, f"{path}.{f.name}")


# --------------------------------------------------------------------------- reading


class _Reader:
    __slots__ = ("data", "pos")

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0

    @property
    def remaining(self) -> int:
        return len(self.data) - self.pos

    def take(self, n: int, path: str) -> bytes:
        if n < 0 or n > self.remaining:
            raise Ros1DecodeError(
                f"{path}: needs {n} byte(s) at offset {self.pos}, only {self.remaining} left (truncated?)"
            )
        chunk = self.data[self.pos : self.pos + n]
        self.pos += n
        return chunk

    def unpack(self, fmt: str, path: str) -> tuple[Any, ...]:
        return struct.unpack(fmt, self.take(struct.calcsize(fmt), path))

    def length(self, path: str) -> int:
        (n,) = self.unpack("<I", path)
        if n > MAX_DECLARED_LENGTH:
            raise Ros1DecodeError(f"{path}: declared length {n} exceeds {MAX_DECLARED_LENGTH}")
        return n


@dataclass(frozen=True)
class Time:
    """ROS ``time``: seconds and nanoseconds since the Unix epoch."""

    secs: int = 0
    nsecs: int = 0

    @classmethod
    def from_ns(cls, stamp_ns: int) -> Time:
        return cls(int(stamp_ns // 1_000_000_000), int(stamp_ns % 1_000_000_000))

    def to_ns(self) -> int:
        return self.secs * 1_000_000_000 + self.nsecs


@dataclass(frozen=True)
class Duration:
    """ROS ``duration``: signed seconds and nanoseconds."""

    secs: int = 0
    nsecs: int = 0


def _read_primitive(reader: _Reader, ftype: str, path: str) -> Any:
    if ftype == "string":
        raw = reader.take(reader.length(path), path)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise Ros1DecodeError(f"{path}: string is not UTF-8: {exc.reason}") from None
    if ftype == "time":
        secs, nsecs = reader.unpack("<II", path)
        return Time(secs, nsecs)
    if ftype == "duration":
        secs, nsecs = reader.unpack("<ii", path)
        return Duration(secs, nsecs)
    (value,) = reader.unpack(PRIMITIVE_FORMATS[ftype], path)
    if ftype == "bool":
        if value not in (0, 1):
            raise Ros1DecodeError(f"{path}: bool byte is {value}, not 0 or 1")
        return bool(value)
    return value


def _read_value(reader: _Reader, spec: FieldSpec, path: str) -> Any:
    base, length = spec.base_type, spec.array_length
    if length is None:
        if base in BUILTIN_TYPES:
            return _read_primitive(reader, base, path)
        return _read_struct(reader, base, path)
    count = reader.length(path) if length == -1 else length
    if base in ("uint8", "char"):
        return reader.take(count, path)
    if base in PRIMITIVE_FORMATS and base != "bool":
        fmt = PRIMITIVE_FORMATS[base]
        raw = reader.take(count * struct.calcsize(fmt), path)
        return tuple(struct.unpack(f"<{count}{fmt[1]}", raw))
    element = FieldSpec(base, spec.name)
    return tuple(_read_value(reader, element, f"{path}[{i}]") for i in range(count))


def _read_struct(reader: _Reader, type_name: str, path: str) -> Any:
    cls = _CLASSES.get(type_name)
    if cls is None:
        raise Ros1DecodeError(f"{path}: no class for ROS 1 type {type_name}")
    values = {f.name: _read_value(reader, f, f"{path}.{f.name}") for f in spec_of(type_name).fields}
    return cls(**values)
