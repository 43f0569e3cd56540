"""The launcher's protective stop of the arm, sent by the thread that learns of a failure first.

When a child dies during a bus job and is not restarted (a safety service mid-episode, the
supervisor above all: nothing else then stops the arm; or any service out of restarts), the
launcher's monitor thread sees its process exit at once (its process file descriptor,
`services.launcher.wakeup`). Before, the stop then went through two more of the launcher's
threads (the stop request's waiter, then the job's loop, which sends it), each a wake and a turn
at the GIL; beside a heavy load (the Rerun viewer replaying a run with software rendering) that
chain once took 133 ms. The monitor now sends the stop itself, first, through this object (the
handover job and the demo alike). The handover job still sends its own stop as it ends, through
the node's same publisher (`ServiceNode.publisher` makes one per topic): one numbering of the
launcher's stops, each recorded.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

log = logging.getLogger(__name__)


class ArmStop:
    """A protective ``motion/stop`` that any thread may send, once per run, while the job's bus
    node is open (`attach`, `detach`: `services.launcher.jobs.run_on_bus`)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._publisher: Any = None
        #: The reason of the stop sent, None until one was.
        self.sent_reason: str | None = None

    def attach(self, publisher: Any) -> None:
        """`publisher`: a `motion/stop` publisher of the job's node (`TypedPublisher`)."""
        with self._lock:
            self._publisher = publisher

    def detach(self) -> None:
        """The job's node is closing: no send starts from here on (one already putting may
        fail with the closing session; `send` never raises)."""
        with self._lock:
            self._publisher = None

    def send(self, reason: str) -> bool:
        """Send ``protective stop: <reason>`` unless a stop was sent already or no node is open;
        True when this call sent it. Never raises (the session may be closing)."""
        with self._lock:
            publisher = self._publisher
            if publisher is None or self.sent_reason is not None:
                return False
            self.sent_reason = reason
        try:
            publisher.put(reason=f"protective stop: {reason}"[:512], protective=True)
        except Exception as exc:  # noqa: BLE001 - closing session: the job's own stop follows
            log.debug("protective stop not sent by the monitor: %s", exc)
            return False
        return True
