"""The common header of every bus message."""

from __future__ import annotations

import msgspec

from bus_schema.types import Seq, ServiceName, StampNs


class Message(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=False):
    """Common header of every message.

    Attributes:
        seq: per-publisher sequence number, starts at 0 and increases by one per message.
        stamp_ns: sender's wall clock (`time.time_ns()`), strictly increasing within one
            sending process even when the host's clock steps back
            (`services.runtime.stamps`). Freshness is judged by local receive time, never by
            comparing clocks; two messages of one source may be ordered by it (a motion goal
            against a stop: `services.motion.goal_filter`).
        source: name of the publishing service (e.g. ``bridge``).
    """

    seq: Seq
    stamp_ns: StampNs
    source: ServiceName
