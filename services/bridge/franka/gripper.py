"""The Franka Hand on a thread of its own, so that the bridge's 100 Hz loop never waits for it.

libfranka's gripper calls block until the action ends (a grasp: until the fingers are
blocked; an open: until they are apart), and a second call waits for the first. The worker
takes the newest `GripAction` only (an older one that did not start is dropped), stops an
action still running before it starts the next (so an open preempts a grasp at once), and
keeps the first error it met for the bridge thread to raise (`HandWorker.error`).
"""

from __future__ import annotations

import logging
import threading
from typing import Any

from services.bridge.franka.core import GripAction
from services.runtime import kv

log = logging.getLogger(__name__)


class HandWorker:
    """Runs Hand actions on a daemon thread.

    Args:
        gripper: a ``franky.Gripper`` (connected).
        speed_m_s: finger speed for grasp and open, m/s.
    """

    def __init__(self, gripper: Any, speed_m_s: float) -> None:
        self.gripper = gripper
        self.speed_m_s = speed_m_s
        self.max_width_m = float(gripper.max_width)
        self.error: BaseException | None = None
        self.sent = {"grasp": 0, "open": 0}
        self._pending: GripAction | None = None
        self._future: Any = None
        self._wake = threading.Condition()
        self._closing = False
        self._thread = threading.Thread(target=self._run, name="franka-hand", daemon=True)
        self._thread.start()

    def request(self, action: GripAction) -> None:
        """Ask for `action` (replacing one that has not started yet)."""
        with self._wake:
            self._pending = action
            self._wake.notify()

    def _run(self) -> None:
        while True:
            with self._wake:
                while self._pending is None and not self._closing:
                    self._wake.wait()
                if self._closing:
                    return
                action, self._pending = self._pending, None
            try:
                self._start(action)
            except Exception as exc:  # noqa: BLE001 - kept for the bridge thread, which raises it
                self.error = exc
                log.warning("franka hand failed", extra=kv(action=action.kind, error=str(exc)))
                return

    def _start(self, action: GripAction | None) -> None:
        if action is None:
            return
        if self._future is not None and not self._future.wait(0):
            self.gripper.stop()  # an action still running: stop it first (an open must not wait)
        if action.kind == "open":
            self._future = self.gripper.move_async(self.max_width_m, self.speed_m_s)
        else:
            # Close until blocked at any width (epsilons span the stroke), then hold the force.
            stroke = self.max_width_m
            self._future = self.gripper.grasp_async(0.0, self.speed_m_s, action.force_n, stroke, stroke)
        self.sent[action.kind] += 1

    def close(self) -> None:
        """Stop the thread (the fingers stay as they are: an object held stays held)."""
        with self._wake:
            self._closing = True
            self._wake.notify()
        self._thread.join(timeout=2.0)
        try:
            if self._future is not None:
                self._future.wait(2.0)  # let libfranka's action thread end before the Hand is freed
        except Exception as exc:  # noqa: BLE001 - shutdown path: the Hand may already be gone
            log.warning("franka hand: %s", exc)
        self._future = None
        self.gripper = None
