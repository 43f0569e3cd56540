"""Every decoder, fuzzed in-process: a payload either decodes to a valid, bounded message or
raises DecodeError. Nothing else, ever (no other exception, no NaN slipping through)."""

from __future__ import annotations

import math
import random

import msgspec
import pytest

from bus_schema import TOPICS, DecodeError, decode
from tests.faults.mutations import random_payloads, structured_payloads
from tests.samples import SAMPLES

TOPIC_IDS = [t.suffix for t in TOPICS]


def _all_floats_finite(value) -> bool:
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, (list, tuple)):
        return all(_all_floats_finite(v) for v in value)
    if isinstance(value, msgspec.Struct):
        return all(_all_floats_finite(getattr(value, f)) for f in value.__struct_fields__)
    return True


def _campaign(topic, payloads) -> tuple[int, int]:
    accepted = rejected = 0
    for payload in payloads:
        try:
            msg = decode(topic, payload)
        except DecodeError:
            rejected += 1
            continue
        assert isinstance(msg, topic.type)
        assert _all_floats_finite(msg), f"non-finite value decoded on {topic.suffix}: {msg}"
        accepted += 1
    return accepted, rejected


@pytest.mark.parametrize("topic", TOPICS, ids=TOPIC_IDS)
def test_decoder_quick_fuzz(topic):
    rng = random.Random(hash(topic.suffix) & 0xFFFF)
    accepted, rejected = _campaign(topic, random_payloads(rng, 1000))
    assert rejected >= 990  # random bytes are almost never a valid message
    accepted, rejected = _campaign(topic, structured_payloads(rng, SAMPLES[topic.suffix], 1000))
    assert rejected > 100 and accepted + rejected == 1000


@pytest.mark.fuzz_full
@pytest.mark.parametrize("topic", TOPICS, ids=TOPIC_IDS)
def test_decoder_full_fuzz(topic):
    """10 000 random + 10 000 structured payloads per message type (DESIGN §8)."""
    rng = random.Random(20261121 + len(topic.suffix))
    a1, r1 = _campaign(topic, random_payloads(rng, 10_000, max_len=4096))
    a2, r2 = _campaign(topic, structured_payloads(rng, SAMPLES[topic.suffix], 10_000))
    assert a1 + r1 == 10_000 and a2 + r2 == 10_000
    assert r2 > 1000  # the mutations really do break messages
