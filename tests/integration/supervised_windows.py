"""Count a service's outputs while a fake supervisor says one phase or another (issue 16: the
tracker and the planner do less while nobody reads their outputs)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any


def outputs_per_window(outputs: Any, send_inputs: Callable[[], None], state_pub: Any,
                       windows: Sequence[tuple[float, str | None]], rate_hz: float = 30.0,
                       state_every: int = 2, settle_s: float = 0.2) -> list[int]:
    """For each window (seconds, phase): call `send_inputs` at `rate_hz` for that long, with a
    `supervisor/state` of `phase` every `state_every` calls (None: the supervisor is silent),
    wait `settle_s` (s) for the last outputs, and count what the subscription `outputs` took."""
    counts = []
    for seconds, phase in windows:
        outputs.drain()
        start = time.monotonic()
        for k in range(round(seconds * rate_hz)):
            send_inputs()
            if phase is not None and k % state_every == 0:
                state_pub.put(phase=phase)
            time.sleep(max(0.0, start + (k + 1) / rate_hz - time.monotonic()))
        time.sleep(settle_s)
        counts.append(len(outputs.drain()))
    return counts
