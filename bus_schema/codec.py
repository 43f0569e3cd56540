"""Encoding and typed decoding at the edge.

One MessagePack encoder for everything, one typed decoder per topic, built once. `decode`
raises `DecodeError` (the package's one exception root is `SchemaError`) for anything that is
not a valid message of the topic's type: wrong bytes, wrong types, out-of-bound values
(NaN, inf, absurd numbers), oversize payloads.
"""

from __future__ import annotations

from typing import Any

import msgspec

from bus_schema.messages import Message
from bus_schema.topics import TOPICS, Topic
from bus_schema.types import MAX_PAYLOAD_BYTES


class SchemaError(Exception):
    """Root of every bus_schema error."""


class DecodeError(SchemaError):
    """A payload is not a valid message of its key's type (the message says why)."""


class EncodeError(SchemaError):
    """A message could not be encoded (too large, or not a message of the topic's type)."""


def _enc_hook(obj: Any) -> Any:
    """Encode numpy scalars and arrays as plain numbers and lists."""
    import numpy as np

    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise NotSupportedType(f"cannot encode objects of type {type(obj).__name__}")


class NotSupportedType(TypeError):
    """A value of a type the bus cannot carry."""


_ENCODER = msgspec.msgpack.Encoder(enc_hook=_enc_hook)
_DECODERS: dict[type, msgspec.msgpack.Decoder] = {
    t.type: msgspec.msgpack.Decoder(t.type) for t in TOPICS
}


def decoder_for(message_type: type[Message]) -> msgspec.msgpack.Decoder:
    """The cached typed decoder of `message_type` (made on first use for extra types)."""
    dec = _DECODERS.get(message_type)
    if dec is None:
        dec = _DECODERS[message_type] = msgspec.msgpack.Decoder(message_type)
    return dec


def encode(message: Message) -> bytes:
    """Encode a message to MessagePack bytes.

    Raises:
        EncodeError: when the encoded payload exceeds `MAX_PAYLOAD_BYTES`.
    """
    try:
        data = _ENCODER.encode(message)
    except TypeError as exc:
        raise EncodeError(f"{type(message).__name__} cannot be encoded: {exc}") from None
    if len(data) > MAX_PAYLOAD_BYTES:
        raise EncodeError(
            f"{type(message).__name__} encodes to {len(data)} bytes, over the "
            f"{MAX_PAYLOAD_BYTES}-byte bus cap"
        )
    return data


def encode_for(topic: Topic, message: Message) -> bytes:
    """Encode `message` for `topic`, checking that it is of the topic's type."""
    if type(message) is not topic.type:
        raise EncodeError(
            f"{topic.suffix} carries {topic.type.__name__}, not {type(message).__name__}"
        )
    return encode(message)


def decode(topic_or_type: Topic | type[Message], payload: bytes | bytearray | memoryview) -> Any:
    """Decode `payload` as the topic's message type, validating every bound.

    Raises:
        DecodeError: with a one-line reason (e.g. ``Expected `float` <= 10000.0 - at
            `$.force_n[1]```).
    """
    message_type = topic_or_type.type if isinstance(topic_or_type, Topic) else topic_or_type
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise DecodeError(f"payload of {len(payload)} bytes exceeds the {MAX_PAYLOAD_BYTES}-byte cap")
    try:
        return decoder_for(message_type).decode(payload)
    except msgspec.ValidationError as exc:
        raise DecodeError(f"invalid {message_type.__name__}: {exc}") from None
    except msgspec.DecodeError as exc:
        raise DecodeError(f"malformed {message_type.__name__} payload: {exc}") from None
    except (ValueError, TypeError, OverflowError, RecursionError) as exc:
        # __post_init__ checks and pathological inputs end up here.
        raise DecodeError(f"invalid {message_type.__name__}: {exc}") from None
