"""Send a command again only when it changed or when its receiver needs a fresh copy.

A service that holds (the gripper's open or carry force, motion's hold position) used to
publish the same command at its full control rate: about 200 identical messages a second on
the idle stack, each crossing the router and woken in the bridge and the recorder. The
bridge keeps acting on the last command until its time-out (0.2 s, `command_timeout_s`),
so a copy every `HOLD_REPEAT_S` keeps it fresh with four copies to spare. A command that
changed, or one the controller stepped, goes out at once.

State that is only sent on a change (the bridge's `sim/truth`, the simulated Kinect's
`sim/kinect_truth`) is compared by `settled_key`: a resting simulation still dithers in its
last bits (the receiver's hand holding the object moves by 1e-19 m, its velocity by 1e-17
m/s), and compared bit for bit such a message "changed" at every tick.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterable

#: Period of the copies of an unchanged command, s (the bridge's command time-out is 0.2 s).
HOLD_REPEAT_S = 0.05


#: Resolution of `settled_key`: 1 nm, 1 nm/s, 1 nN (far below any sensor or plot of the
#: stack; far above the 1e-15 rounding dither of a resting simulation).
SETTLED_RESOLUTION = 1e-9


def settled_key(values: Iterable[object], resolution: float = SETTLED_RESOLUTION) -> tuple:
    """A hashable key of message field values with every finite float rounded to a multiple
    of `resolution` (nested tuples and lists too); two keys differ when some value changed by
    more than about `resolution`. Non-finite floats, strings, bools and ints are kept as they are."""
    def key(value: object) -> object:
        if type(value) is float:
            steps = value / resolution
            return round(steps) if math.isfinite(steps) else value  # inf, NaN, or beyond 1e299
        if isinstance(value, (tuple, list)):
            return tuple(key(v) for v in value)
        return value
    return tuple(key(v) for v in values)


class RepeatGate:
    """Decides, per call, whether a command must be published.

    Args:
        repeat_s: an unchanged command goes out again once this long after its last copy, s.
    """

    def __init__(self, repeat_s: float = HOLD_REPEAT_S) -> None:
        if not repeat_s > 0.0:
            raise ValueError(f"repeat_s must be > 0 s, got {repeat_s!r}")
        self.repeat_s = float(repeat_s)
        self._last: Hashable | None = None
        self._last_s = -float("inf")
        self.sent = 0
        self.skipped = 0

    def due(self, command: Hashable, now_s: float, always: bool = False) -> bool:
        """True when `command` must go out at `now_s` (monotonic s): `always` (a step of the
        controller), a change from the last command sent, or `repeat_s` since its last copy.
        A True answer records the command as sent."""
        if always or command != self._last or now_s - self._last_s >= self.repeat_s:
            self._last, self._last_s = command, now_s
            self.sent += 1
            return True
        self.skipped += 1
        return False
