"""The handover bus contract: messages, keys, codec and schema version.

Import from here: ``from bus_schema import topics, messages, encode, decode``.
"""

from bus_schema import messages, topics
from bus_schema.codec import DecodeError, EncodeError, SchemaError, decode, decoder_for, encode, encode_for
from bus_schema.topics import DEFAULT_PREFIX, SCHEMA_VERSION, TOPICS, Topic, alive_key, topic_for_key
from bus_schema.types import MAX_PAYLOAD_BYTES

__all__ = [
    "DEFAULT_PREFIX",
    "MAX_PAYLOAD_BYTES",
    "SCHEMA_VERSION",
    "TOPICS",
    "DecodeError",
    "EncodeError",
    "SchemaError",
    "Topic",
    "alive_key",
    "decode",
    "decoder_for",
    "encode",
    "encode_for",
    "messages",
    "topic_for_key",
    "topics",
]
