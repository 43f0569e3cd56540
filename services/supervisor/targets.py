"""The planner's transfer target, steadied by a median over a sliding window (pure, no I/O)."""

from __future__ import annotations

import msgspec
import numpy as np

from bus_schema.messages import TransferTarget


class TargetFilter:
    """The planner's transfer target, steadied: the component-wise median of the targets
    received over the last `window_s` seconds. The DJT optimum moves a few cm from frame to
    frame with the tracker's body estimates; a median keeps that noise from looking like a
    receiver who moved (which would start a new reach).

    Args:
        window_s: length of the median window, s.
    """

    def __init__(self, window_s: float = 1.0) -> None:
        self.window_s = window_s
        self._items: list[tuple[float, TransferTarget]] = []
        self._current: TransferTarget | None = None  # of the window as it is now
        self._stale = True

    def offer(self, target: TransferTarget, rx_s: float) -> None:
        self._items.append((rx_s, target))
        self._stale = True

    def current(self, now_s: float) -> TransferTarget | None:
        """The latest target with its position replaced by the window's median (None when
        nothing was received within the window). Computed again only when the window's
        contents changed (the supervisor asks at 100 Hz; targets come at about 5 Hz)."""
        items = self._items
        first = 0
        while first < len(items) and now_s - items[first][0] > self.window_s:
            first += 1
        if first:
            del items[:first]
            self._stale = True
        if not items:
            self._current = None
            return None
        if self._stale:
            latest = items[-1][1]
            median = np.median(np.array([m.position_base_m for _, m in items]), axis=0)
            self._current = msgspec.structs.replace(latest, position_base_m=tuple(float(v) for v in median))
            self._stale = False
        return self._current
