"""Who is alive on the bus: liveliness-token queries and a watcher.

A service's token is ``<prefix>/alive/<service>``; it disappears within milliseconds when the
process dies (a frozen process keeps it until the link lease expires, so watch data freshness
as well).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import zenoh

from bus_schema.topics import ALIVE_SUFFIX


def alive_services(session: zenoh.Session, prefix: str, timeout_s: float = 0.5) -> set[str]:
    """Names of the services whose liveliness token is up now."""
    head = f"{prefix}/{ALIVE_SUFFIX}/"
    names: set[str] = set()
    replies = session.liveliness().get(head + "*", timeout=timeout_s)
    for reply in replies:
        sample = reply.ok
        if sample is None:  # an error reply
            continue
        key = str(sample.key_expr)
        if key.startswith(head):
            names.add(key[len(head):])
    return names


class LivelinessWatcher:
    """Tracks the alive set through a liveliness subscriber (with history).

    `on_change(name, alive)` is called from a Zenoh thread: it must only record or enqueue.
    """

    def __init__(self, session: zenoh.Session, prefix: str,
                 on_change: Callable[[str, bool], None] | None = None) -> None:
        self._head = f"{prefix}/{ALIVE_SUFFIX}/"
        self._lock = threading.Lock()
        self._alive: dict[str, float] = {}
        self._events: list[tuple[float, str, bool]] = []
        self._on_change = on_change
        self._sub = session.liveliness().declare_subscriber(
            self._head + "*", self._on_sample, history=True
        )

    def _on_sample(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if not key.startswith(self._head):
            return
        name = key[len(self._head):]
        alive = sample.kind == zenoh.SampleKind.PUT
        now = time.monotonic()
        with self._lock:
            if alive:
                self._alive[name] = now
            else:
                self._alive.pop(name, None)
            self._events.append((now, name, alive))
        if self._on_change is not None:
            self._on_change(name, alive)

    def alive(self) -> set[str]:
        with self._lock:
            return set(self._alive)

    def events(self) -> list[tuple[float, str, bool]]:
        """(monotonic time, service, alive) for every change seen so far."""
        with self._lock:
            return list(self._events)

    def wait_for(self, names: set[str], timeout_s: float) -> set[str]:
        """Wait until all `names` are alive; return those still missing (empty: all up)."""
        deadline = time.monotonic() + timeout_s
        while True:
            missing = names - self.alive()
            if not missing or time.monotonic() >= deadline:
                return missing
            time.sleep(0.01)

    def undeclare(self) -> None:
        try:
            self._sub.undeclare()
        except Exception:  # noqa: BLE001 - best-effort close: the session may already be closed
            pass
