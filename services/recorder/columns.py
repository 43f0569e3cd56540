"""The recording's two timelines and their Arrow index columns.

Every row the recorder writes carries both: ``time`` (the sender's `stamp_ns`) and
``receive_time`` (when the recorder's Zenoh callback got the message), ns since the epoch.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa

TIMELINE_STAMP = "time"
TIMELINE_RECEIVE = "receive_time"


def index_field(name: str) -> pa.Field:
    """Arrow field of a timestamp timeline column `name` (Rerun's index metadata)."""
    return pa.field(name, pa.timestamp("ns"), metadata={b"rerun:kind": b"index", b"rerun:index_name": name.encode()})


#: The Arrow fields of the two timelines.
INDEX_FIELDS: tuple[pa.Field, pa.Field] = (index_field(TIMELINE_STAMP), index_field(TIMELINE_RECEIVE))


def time_arrays(stamps_ns: np.ndarray, receives_ns: np.ndarray) -> tuple[pa.Array, pa.Array]:
    """The ``time`` and ``receive_time`` columns of a batch (int64 ns since the epoch)."""
    return (pa.array(np.asarray(stamps_ns, dtype=np.int64)).view(pa.timestamp("ns")),
            pa.array(np.asarray(receives_ns, dtype=np.int64)).view(pa.timestamp("ns")))
