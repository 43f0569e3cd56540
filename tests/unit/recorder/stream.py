"""A synthetic bus stream at the stack's measured idle rates, for recorder tests and benchmarks.

`idle_stream(seconds)` returns (send offset s, key, payload) for every message the running stack
publishes in `seconds` (rates measured on an idle `handover-up`, `IDLE_RATES_HZ`: ≈ 1 050
messages/s with depth). Every message is a real bus message (the `tests.samples` message of its
key, encoded with `bus_schema`); every float of every message varies smoothly with time (its own
sine per field), so the recording's compression sees changing numbers as in a handover, not
constants. Depth images are 320 × 240 (150 kB): a tilted floor, a box and ±2 mm of noise.
"""

from __future__ import annotations

import math
from typing import Any

import msgspec
import numpy as np

from bus_schema import encode_for, messages as m, topics
from bus_schema.topics import TOPICS_BY_SUFFIX
from tests.samples import SAMPLES

PREFIX = "handover/v1"

#: Messages per second per key of the idle stack (measured on the bus; heartbeats: 8 services).
IDLE_RATES_HZ: dict[str, float] = {
    topics.HEARTBEAT.suffix: 156.0,
    topics.JOINT_STATE.suffix: 100.0,
    topics.JOINT_COMMAND.suffix: 100.0,
    topics.WRIST_WRENCH.suffix: 100.0,
    topics.OBJECT_MOTION.suffix: 100.0,
    topics.SIM_TRUTH.suffix: 100.0,
    topics.GRIPPER_COMMAND.suffix: 130.0,
    topics.GRIPPER_STATE.suffix: 70.0,
    topics.SKELETON.suffix: 30.0,
    topics.DEPTH.suffix: 30.0,
    topics.KINECT_TRUTH.suffix: 30.0,
    topics.HUMAN.suffix: 30.0,
    topics.MOTION_STATUS.suffix: 50.0,
    topics.SUPERVISOR_STATE.suffix: 10.0,
    topics.TRANSFER.suffix: 5.0,
}

HEARTBEAT_SOURCES = ("recorder", "bridge", "kinect", "tracker", "planner", "motion", "gripper", "supervisor")
DEPTH_SHAPE = (240, 320)
TICK_S = 0.01


def depth_frame(rng: np.random.Generator) -> bytes:
    """One 320 × 240 depth image (mm, little-endian uint16): floor, a box, sensor noise."""
    rows, cols = np.mgrid[0 : DEPTH_SHAPE[0], 0 : DEPTH_SHAPE[1]]
    depth = 1200.0 + 4.0 * rows + 0.5 * cols
    depth[80:160, 120:200] -= 300.0
    depth += rng.integers(-2, 3, DEPTH_SHAPE)
    return depth.astype("<u2").tobytes()


def _vary(value: Any, t_s: float, salt: list[int]) -> Any:
    """`value` with every float scaled by 1 - 0.025 (1 + sin(ω t + φ)) (ω, φ differ per field;
    magnitudes only shrink, so every bound of the message types still holds)."""
    if isinstance(value, bool) or isinstance(value, (int, str, bytes)) or value is None:
        return value
    if isinstance(value, float):
        salt[0] += 1
        k = salt[0]
        return value * (1.0 - 0.025 * (1.0 + math.sin(2 * math.pi * (0.2 + 0.07 * k) * t_s + k)))
    if isinstance(value, (list, tuple)):
        return type(value)(_vary(v, t_s, salt) for v in value)
    if isinstance(value, dict):
        return {k: _vary(v, t_s, salt) for k, v in value.items()}
    return value


def message_at(suffix: str, t_s: float, seq: int, stamp_ns: int, source: str | None = None,
               depth_mm: bytes | None = None) -> m.Message:
    """The sample message of `suffix` at time `t_s` (floats varied), with header fields set."""
    topic = TOPICS_BY_SUFFIX[suffix]
    fields = msgspec.to_builtins(SAMPLES[suffix])
    fields = _vary(fields, t_s, [0])
    fields.update(seq=seq, stamp_ns=stamp_ns)
    if source is not None:
        fields["source"] = source
    if suffix == topics.DEPTH.suffix:
        fields.update(width=DEPTH_SHAPE[1], height=DEPTH_SHAPE[0])
        fields["depth_mm"] = depth_mm
    if suffix == topics.HEARTBEAT.suffix:
        fields.update(uptime_s=t_s, beats=seq)
    return msgspec.convert(fields, topic.type)


def idle_stream(seconds: float, rates_hz: dict[str, float] | None = None, prefix: str = PREFIX,
                t0_ns: int | None = None, seed: int = 3) -> list[tuple[float, str, bytes]]:
    """(send offset s, key, payload) of every message of `seconds` of the idle stack, in send order.

    Stamps are `t0_ns` + the offset (+ a ns per message, so that they are unique per key).
    """
    rates = IDLE_RATES_HZ if rates_hz is None else rates_hz
    rng = np.random.default_rng(seed)
    depth_frames = [depth_frame(rng) for _ in range(4)] if topics.DEPTH.suffix in rates else []
    t0_ns = t0_ns if t0_ns is not None else 1_763_000_000_000_000_000
    owed = dict.fromkeys(rates, 0.0)
    seqs = dict.fromkeys(rates, 0)
    out: list[tuple[float, str, bytes]] = []
    for tick in range(int(round(seconds / TICK_S))):
        t_s = tick * TICK_S
        for suffix, rate in rates.items():
            owed[suffix] += rate * TICK_S
            while owed[suffix] >= 1.0 - 1e-9:
                owed[suffix] -= 1.0
                n = seqs[suffix]
                seqs[suffix] += 1
                source = HEARTBEAT_SOURCES[n % len(HEARTBEAT_SOURCES)] if suffix == topics.HEARTBEAT.suffix else None
                depth = depth_frames[n % len(depth_frames)] if depth_frames and suffix == topics.DEPTH.suffix else None
                msg = message_at(suffix, t_s, n, t0_ns + int(t_s * 1e9) + len(out), source, depth)
                topic = TOPICS_BY_SUFFIX[suffix]
                out.append((t_s, topic.sender_key(msg.source, prefix), encode_for(topic, msg)))
    return out
