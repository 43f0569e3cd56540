"""Payload generators for fuzzing: random bytes and structured mutations of valid messages."""

from __future__ import annotations

import math
import random
from collections.abc import Iterator
from typing import Any

import msgspec

_WEIRD_VALUES: tuple[Any, ...] = (
    math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, 0, -1, 2**63, -(2**63) - 1, 2**64,
    "", "x" * 10_000, "\x00\ud7ff", "😀", None, True, [], {}, b"", b"\xff" * 100,
    [1.0] * 100, [[[[[]]]]], {"a": {"b": {"c": 1}}}, 3.5, -0.0, "nan",
)


def random_payloads(rng: random.Random, count: int, max_len: int = 512) -> Iterator[bytes]:
    """Uniformly random byte strings of random length (0..max_len)."""
    for _ in range(count):
        yield rng.randbytes(rng.randint(0, max_len))


def _mutate_doc(rng: random.Random, doc: Any, depth: int = 0) -> Any:
    """Return a structurally mutated copy of a builtins document."""
    if isinstance(doc, dict) and doc:
        doc = dict(doc)
        key = rng.choice(list(doc))
        action = rng.random()
        if action < 0.45:
            doc[key] = rng.choice(_WEIRD_VALUES)
        elif action < 0.6:
            del doc[key]
        elif action < 0.7:
            doc["unknown_" + str(rng.randint(0, 99))] = rng.choice(_WEIRD_VALUES)
        else:
            doc[key] = _mutate_doc(rng, doc[key], depth + 1)
        return doc
    if isinstance(doc, list):
        doc = list(doc)
        action = rng.random()
        if not doc or action < 0.2:
            return doc + [rng.choice(_WEIRD_VALUES)] * rng.choice([1, 5, 40])
        if action < 0.35:
            return []
        if action < 0.5:
            return doc * rng.choice([2, 10, 200])
        i = rng.randrange(len(doc))
        doc[i] = _mutate_doc(rng, doc[i], depth + 1) if rng.random() < 0.5 else rng.choice(_WEIRD_VALUES)
        return doc
    if isinstance(doc, float):
        return rng.choice([doc * 1e6, -doc, math.nan, math.inf, doc + rng.gauss(0, 1)])
    if isinstance(doc, bool):
        return rng.choice([not doc, 1, "true"])
    if isinstance(doc, int):
        return rng.choice([doc + 1, -doc - 1, 2**70, doc * 1000, float(doc)])
    if isinstance(doc, str):
        return rng.choice(["", doc * 100, doc.upper(), doc + "!", "ü" * 70])
    return rng.choice(_WEIRD_VALUES)


def _mutate_bytes(rng: random.Random, data: bytes) -> bytes:
    buf = bytearray(data)
    action = rng.random()
    if action < 0.3 and buf:
        for _ in range(rng.randint(1, 4)):
            buf[rng.randrange(len(buf))] = rng.randrange(256)
    elif action < 0.5:
        buf = buf[: rng.randrange(len(buf) + 1)]
    elif action < 0.7:
        pos = rng.randrange(len(buf) + 1)
        buf[pos:pos] = rng.randbytes(rng.randint(1, 16))
    elif action < 0.85 and buf:
        # A msgpack length prefix claiming far more than is there.
        buf[rng.randrange(len(buf))] = rng.choice([0xDC, 0xDD, 0xDE, 0xDF, 0xC6, 0xDB])
    else:
        buf = buf + buf
    return bytes(buf)


def structured_payloads(rng: random.Random, valid: msgspec.Struct, count: int) -> Iterator[bytes]:
    """Mutations of a valid message: field-level (types, bounds, missing/extra fields, sizes)
    on the decoded document, and byte-level (flips, truncation, bogus length prefixes) on the
    encoding. Every mutation starts from the valid message, so most are near-valid."""
    base_doc = msgspec.to_builtins(valid)
    base_bytes = msgspec.msgpack.encode(valid)
    for i in range(count):
        if i % 3 == 2:
            yield _mutate_bytes(rng, base_bytes)
            continue
        doc = base_doc
        for _ in range(rng.choice([1, 1, 2, 3])):
            doc = _mutate_doc(rng, doc)
        try:
            yield msgspec.msgpack.encode(doc)
        except (TypeError, OverflowError, ValueError):
            yield base_bytes[: len(base_bytes) // 2]
