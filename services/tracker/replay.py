"""Record and replay files of skeleton, depth, joint state and sim truth messages.

Format: the 8-byte magic ``HOTRACK1``, then records, each a 4-byte little-endian length and
a MessagePack `ReplayRecord` (time since the start of the recording in seconds, the topic's
key suffix, and the message exactly as it travels on the bus). Payloads are decoded with the
bus's typed decoders, so a replayed message is validated like a live one.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

from bus_schema import topics as T
from bus_schema.codec import DecodeError, decode, encode
from services.tracker.errors import ReplayFileError

MAGIC = b"HOTRACK1"
#: Topics a replay file may hold.
REPLAY_TOPICS = {t.suffix: t for t in (T.SKELETON, T.DEPTH, T.JOINT_STATE, T.SIM_TRUTH)}
_LEN = struct.Struct("<I")
MAX_RECORD_BYTES = 2 << 20


class ReplayRecord(msgspec.Struct, frozen=True):
    """One stored message: `t_s` (s since the recording started), `topic` suffix, `payload`."""

    t_s: float
    topic: str
    payload: bytes


@dataclass(frozen=True)
class ReplayItem:
    """A decoded record: time (s), topic, message."""

    t_s: float
    topic: T.Topic
    msg: Any


class ReplayWriter:
    """Append messages to a replay file (context manager)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("wb")
        except OSError as exc:
            raise ReplayFileError(f"cannot write replay file {self.path}: {exc.strerror}") from None
        self._file.write(MAGIC)
        self._enc = msgspec.msgpack.Encoder()
        self.records = 0

    def write(self, t_s: float, topic: T.Topic, msg: Any) -> None:
        """Store `msg` of `topic` at time `t_s`."""
        if topic.suffix not in REPLAY_TOPICS:
            raise ReplayFileError(f"topic {topic.suffix} cannot be recorded (only {sorted(REPLAY_TOPICS)})")
        data = self._enc.encode(ReplayRecord(float(t_s), topic.suffix, encode(msg)))
        self._file.write(_LEN.pack(len(data)))
        self._file.write(data)
        self.records += 1

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> ReplayWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_replay(path: str | Path) -> Iterator[ReplayItem]:
    """Records of a replay file, in order.

    Raises:
        ReplayFileError: missing file, wrong format, truncated or invalid record (the message
            names the record).
    """
    path = Path(path)
    try:
        f = path.open("rb")
    except OSError as exc:
        raise ReplayFileError(f"cannot open replay file {path}: {exc.strerror}") from None
    dec = msgspec.msgpack.Decoder(ReplayRecord)
    with f:
        if f.read(len(MAGIC)) != MAGIC:
            raise ReplayFileError(f"{path} is not a tracker replay file (no {MAGIC.decode()} header)")
        index = 0
        while True:
            head = f.read(_LEN.size)
            if not head:
                return
            if len(head) < _LEN.size:
                raise ReplayFileError(f"{path}: truncated after record {index}")
            (n,) = _LEN.unpack(head)
            if n > MAX_RECORD_BYTES:
                raise ReplayFileError(f"{path}: record {index} claims {n} bytes, over {MAX_RECORD_BYTES}")
            data = f.read(n)
            if len(data) < n:
                raise ReplayFileError(f"{path}: record {index} truncated ({len(data)} of {n} bytes)")
            try:
                rec = dec.decode(data)
                topic = REPLAY_TOPICS[rec.topic]
                msg = decode(topic, rec.payload)
            except (msgspec.DecodeError, msgspec.ValidationError, KeyError, DecodeError) as exc:
                raise ReplayFileError(f"{path}: record {index} is invalid: {exc}") from None
            yield ReplayItem(rec.t_s, topic, msg)
            index += 1
