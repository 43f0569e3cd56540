"""Send a command again only when it changed or when its receiver needs a fresh copy.

A service that holds (the gripper's open or carry force, motion's hold position) used to
publish the same command at its full control rate: about 200 identical messages a second on
the idle stack, each crossing the router and woken in the bridge and the recorder. The
bridge keeps acting on the last command until its time-out (0.2 s, `command_timeout_s`),
so a copy every `HOLD_REPEAT_S` keeps it fresh with four copies to spare. A command that
changed, or one the controller stepped, goes out at once.
"""

from __future__ import annotations

from collections.abc import Hashable

#: Period of the copies of an unchanged command, s (the bridge's command time-out is 0.2 s).
HOLD_REPEAT_S = 0.05


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
