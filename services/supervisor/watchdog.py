"""Who is lost or silent: liveliness, heartbeats and data freshness (pure, no I/O).

- **Lost** (the process died): its liveliness token went away. Zenoh notices a killed
  process within milliseconds (the link closes).
- **Silent** (frozen, hung or cut off): its heartbeat (`runtime/heartbeat`, 20 Hz) is older
  than `heartbeat_timeout_s`, or one of the data streams it owns that the handover relies on
  is older than `stream_timeout_s`. A frozen process keeps its liveliness token until the
  link lease expires (seconds), so freshness is what catches it.

Freshness is judged on the local monotonic clock at receive time, never on the sender's
stamps. A service is only judged once it has been seen (alive, beating, publishing): a
service still starting is not a fault. Each fault is reported once, and again only after the
service has recovered.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Fault:
    """A service that is lost or silent.

    Attributes:
        service: the service's name.
        what: ``lost`` (liveliness gone) or ``silent``.
        detail: one line (e.g. ``no heartbeat for 0.21 s``).
        noticed_s: local monotonic time of the notice, s.
        since_s: when the problem began (liveliness loss, or the last message), s.
    """

    service: str
    what: str
    detail: str
    noticed_s: float
    since_s: float

    def text(self) -> str:
        return f"{self.service}: {self.detail}"


@dataclass
class _Watched:
    seen: bool = False
    alive: bool = False
    lost_at_s: float | None = None
    last_beat_s: float | None = None
    streams: dict[str, float] = field(default_factory=dict)
    reported: bool = False


class Watchdog:
    """Tracks the watched services and reports new faults.

    Args:
        services: names of the services to watch.
        heartbeat_timeout_s: heartbeat age that makes a service silent, s.
        stream_timeout_s: age of an owned data stream that makes its service silent, s.
        streams: data stream (topic suffix) → owning service, for the streams to watch.
        heartbeat_timeouts_s: per-service heartbeat age overriding `heartbeat_timeout_s`
            (report-only services, e.g. the recorder, which may stall in long writes), s.
    """

    def __init__(self, services: list[str], heartbeat_timeout_s: float = 0.25, stream_timeout_s: float = 0.2,
                 streams: dict[str, str] | None = None,
                 heartbeat_timeouts_s: dict[str, float] | None = None) -> None:
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.heartbeat_timeouts_s = dict(heartbeat_timeouts_s or {})
        self.stream_timeout_s = stream_timeout_s
        self.stream_owner = dict(streams or {})
        self._w: dict[str, _Watched] = {name: _Watched() for name in services}

    @property
    def services(self) -> list[str]:
        return list(self._w)

    def all_alive(self) -> bool:
        return all(w.alive for w in self._w.values())

    def missing(self) -> list[str]:
        return sorted(n for n, w in self._w.items() if not w.alive)

    # ------------------------------------------------------------------ inputs
    def liveliness(self, service: str, alive: bool, at_s: float) -> None:
        w = self._w.get(service)
        if w is None:
            return
        if alive:
            if not w.alive:
                w.reported = False  # a restarted service is judged afresh
                w.last_beat_s = None
                w.streams.clear()
            w.seen, w.alive, w.lost_at_s = True, True, None
        elif w.alive:
            w.alive, w.lost_at_s = False, at_s

    def heartbeat(self, service: str, at_s: float) -> None:
        w = self._w.get(service)
        if w is not None:
            w.last_beat_s = at_s
            if w.reported and w.alive:
                w.reported = False  # it came back (e.g. SIGCONT)

    def stream(self, suffix: str, at_s: float) -> None:
        owner = self.stream_owner.get(suffix)
        w = self._w.get(owner) if owner else None
        if w is not None:
            w.streams[suffix] = at_s

    # ------------------------------------------------------------------ judging
    def check(self, now_s: float) -> list[Fault]:
        """New faults at local time `now_s` (each reported once until recovery)."""
        out = self.pending(now_s)
        for fault in out:
            self._w[fault.service].reported = True
        return out

    def pending(self, now_s: float) -> list[Fault]:
        """The faults `check` would report at `now_s`, without reporting them."""
        out = []
        for name, w in self._w.items():
            if w.reported or not w.seen:
                continue
            fault = None
            if not w.alive:
                fault = Fault(name, "lost", "process gone (liveliness token lost)", now_s, w.lost_at_s or now_s)
            elif (w.last_beat_s is not None
                  and now_s - w.last_beat_s > self.heartbeat_timeouts_s.get(name, self.heartbeat_timeout_s)):
                fault = Fault(name, "silent", f"silent: no heartbeat for {now_s - w.last_beat_s:.3f} s",
                              now_s, w.last_beat_s)
            else:
                for suffix, at_s in w.streams.items():
                    if now_s - at_s > self.stream_timeout_s:
                        fault = Fault(name, "silent", f"silent: no {suffix} for {now_s - at_s:.3f} s", now_s, at_s)
                        break
            if fault is not None:
                out.append(fault)
        return out
