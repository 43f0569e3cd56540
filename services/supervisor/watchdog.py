"""Who is lost or silent: liveliness, heartbeats and data freshness (pure, no I/O).

- **Lost** (the process died): its liveliness token went away (Zenoh notices a killed
  process within milliseconds when the router gets a CPU), or, on one host, the kernel says
  its process ended (`excuser.exited()`, a process file descriptor: no bus in between).
- **Silent** (frozen, hung or cut off): its heartbeat (`runtime/heartbeat`, 10 Hz on one host) is older
  than `heartbeat_timeout_s`, or one of the data streams it owns that the handover relies on
  is older than `stream_timeout_s`. A frozen process keeps its liveliness token until the
  link lease expires (seconds), so freshness is what catches it.

Freshness is judged on the local monotonic clock at receive time, never on the sender's
stamps. A service is only judged once it has been seen (alive, beating, publishing): a
service still starting is not a fault. Each fault is reported once, and again only after the
service has recovered.

On one host a silence can be excused as starvation (`excuser`, see
`services.runtime.sched`): a process whose threads spent the silence waiting on the kernel's
run queue is alive and runnable, only not given a CPU (a busy machine). It is judged silent
once its silence passes `max_excused_s` whatever the reason; a stopped (SIGSTOP), blocked or
spinning process is never excused.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from services.supervisor.errors import SupervisorConfigError


class Excuser(Protocol):
    """Says whether a quiet service is starved of CPU (see `services.runtime.sched`)."""

    def note(self, service: str, now_s: float, quiet_since_s: float | None = None) -> None:
        """The service has been quiet since `quiet_since_s` (monotonic s): take readings to
        judge it later."""

    def excuse(self, service: str, now_s: float) -> str | None:
        """Why its silence is starvation (one clause), or None."""

    def tick(self, now_s: float) -> None:
        """Called at every check: keep whatever must be known from before a silence began."""

    def exited(self) -> set[str]:
        """The services whose process has ended (known without the bus), or an empty set."""

    def stopped(self, service: str, now_s: float) -> bool:
        """True when the service's process is stopped (SIGSTOP) now, as the kernel says."""

    def revived(self, service: str) -> None:
        """The service is alive again (a restart): forget what was known of its old process."""


@dataclass(frozen=True)
class Fault:
    """A service that is lost or silent.

    Attributes:
        service: the service's name.
        what: ``lost`` (liveliness gone) or ``silent``.
        detail: one line (e.g. ``no heartbeat for 0.21 s``).
        noticed_s: local time of the notice, s (a heartbeat's silence: on the wall clock, as
            `since_s`; on the simulation clock the other faults are on simulated time).
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


def judging_for_beats(period_s: float) -> dict[str, float]:
    """`Watchdog` settings for heartbeats every `period_s` (s): a service is noted to the
    excuser once a beat is 10 ms overdue (``note_after_s``) and, when its process is stopped,
    silent once a beat is 30 ms overdue (``stopped_after_s``): at 10 Hz on one host a stopped
    service is silent 0.13 s after its last beat at the latest."""
    return {"note_after_s": period_s + 0.01, "stopped_after_s": period_s + 0.03}


#: How late a heartbeat may come before its service is judged silent, s (the profile's
#: `heartbeat_timeout_s` is refused below one period and `MIN_BEAT_LATENESS_S`).
BEAT_LATENESS_S = 0.15
MIN_BEAT_LATENESS_S = 0.05


def default_heartbeat_timeout_s(period_s: float) -> float:
    """The heartbeat age that makes a service silent when the profile does not say, s: one
    beat period and `BEAT_LATENESS_S` (0.25 s at 10 Hz on one host, 0.2 s at 20 Hz across
    hosts): a beat may come 0.15 s late before its service is judged, as with 20 Hz beats
    and the 0.2 s of before."""
    return period_s + BEAT_LATENESS_S


def resolve_heartbeat_timeout_s(configured_s: float | None, period_s: float) -> float:
    """The heartbeat time-out in force, s: the profile's (`configured_s`) or the default for
    beats every `period_s`.

    Raises:
        SupervisorConfigError: a configured time-out shorter than one period and
            `MIN_BEAT_LATENESS_S` (every service would look silent between two beats).
    """
    timeout_s = configured_s or default_heartbeat_timeout_s(period_s)
    if timeout_s < period_s + MIN_BEAT_LATENESS_S:
        raise SupervisorConfigError(
            f"invalid [services.supervisor.config]: heartbeat_timeout_s = {timeout_s:g} s is shorter than one "
            f"heartbeat period ({period_s:g} s) and {MIN_BEAT_LATENESS_S:g} s: every service would look silent "
            f"(omit it for the default, {default_heartbeat_timeout_s(period_s):g} s)")
    return timeout_s


class Watchdog:
    """Tracks the watched services and reports new faults.

    Args:
        services: names of the services to watch.
        heartbeat_timeout_s: heartbeat age that makes a service silent, s.
        stream_timeout_s: age of an owned data stream that makes its service silent, s.
        streams: data stream (topic suffix) → owning service, for the streams to watch.
        heartbeat_timeouts_s: per-service heartbeat age overriding `heartbeat_timeout_s`
            (report-only services, e.g. the recorder, which may stall in long writes), s.
        excuser: judges a silence as starvation (None: never excused).
        max_excused_s: a silence this long is a fault even when excused, s.
        note_after_s: a service without a heartbeat this long is noted to the excuser at
            each check, s (`judging_for_beats`: one beat period and 10 ms).
        stream_note_after_s: the same for an owned data stream, s.
        stopped_after_s: a service without a heartbeat this long whose process the excuser
            finds stopped (SIGSTOP, state ``T``) is silent at once, without waiting for
            `heartbeat_timeout_s`: nothing but a SIGCONT can make it beat again, s.
    """

    def __init__(self, services: list[str], heartbeat_timeout_s: float = 0.25, stream_timeout_s: float = 0.2,
                 streams: dict[str, str] | None = None,
                 heartbeat_timeouts_s: dict[str, float] | None = None, excuser: Excuser | None = None,
                 max_excused_s: float = 1.0, note_after_s: float = 0.06, stopped_after_s: float = 0.1,
                 stream_note_after_s: float = 0.06) -> None:
        self.excuser = excuser
        self.max_excused_s = max_excused_s
        self.note_after_s = note_after_s
        self.stream_note_after_s = stream_note_after_s
        self.stopped_after_s = stopped_after_s
        self.excused: list[tuple[str, str]] = []  # (service, why) of the last `pending` call
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
                if w.seen and self.excuser is not None:
                    self.excuser.revived(service)
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
    def check(self, now_s: float, wall_now_s: float | None = None) -> list[Fault]:
        """New faults at local time `now_s` (each reported once until recovery).

        `wall_now_s`: on the simulation clock, the local monotonic time (s): heartbeats, and
        the excuser's readings, are timed on it (liveness is a wall-clock matter) and the data
        streams on `now_s` (simulated time). None: one clock for both."""
        out = self.pending(now_s, wall_now_s)
        for fault in out:
            self._w[fault.service].reported = True
        return out

    def pending(self, now_s: float, wall_now_s: float | None = None) -> list[Fault]:
        """The faults `check` would report at `now_s`, without reporting them (silences the
        excuser excuses are listed in `excused` instead)."""
        out = []
        self.excused = []
        exited: set[str] = set()
        wall_s = now_s if wall_now_s is None else wall_now_s
        if self.excuser is not None:
            self.excuser.tick(wall_s)
            exited = self.excuser.exited()
        for name, w in self._w.items():
            if w.reported or not w.seen:
                continue
            if not w.alive or name in exited:
                detail = "process gone (liveliness token lost)" if not w.alive else "process gone (it exited)"
                out.append(Fault(name, "lost", detail, now_s, w.lost_at_s or now_s))
                continue
            fault, excusable, on_wall = self._silence(name, w, now_s, wall_s)
            if fault is None:
                continue
            why = None
            silent_for_s = (wall_s if on_wall else now_s) - fault.since_s
            if excusable and self.excuser is not None and silent_for_s <= self.max_excused_s:
                why = self.excuser.excuse(name, wall_s)
            if why is None:
                out.append(fault)
            else:
                self.excused.append((name, f"{fault.detail}, excused: starved of CPU ({why})"))
        return out

    def _silence(self, name: str, w: _Watched, now_s: float, wall_s: float) -> tuple[Fault | None, bool, bool]:
        """The silence fault of one live service at `now_s` (None: it is not silent), whether
        starvation may excuse it (not when its process is stopped) and whether it was timed on
        the wall clock `wall_s` (a heartbeat's); a service quiet for `note_after_s` is noted
        to the excuser."""
        timeout_s = self.heartbeat_timeouts_s.get(name, self.heartbeat_timeout_s)
        beat_quiet_s = 0.0 if w.last_beat_s is None else wall_s - w.last_beat_s
        quiet_s = 0.0  # of the owned streams
        fault, on_wall = None, True
        if w.last_beat_s is not None and beat_quiet_s > timeout_s:
            fault = Fault(name, "silent", f"silent: no heartbeat for {beat_quiet_s:.3f} s", wall_s, w.last_beat_s)
        else:
            on_wall = wall_s == now_s
            for suffix, at_s in w.streams.items():
                quiet_s = max(quiet_s, now_s - at_s)
                if now_s - at_s > self.stream_timeout_s:
                    fault = Fault(name, "silent", f"silent: no {suffix} for {now_s - at_s:.3f} s", now_s, at_s)
                    break
        if (fault is None and w.last_beat_s is not None and self.excuser is not None
                and beat_quiet_s > self.stopped_after_s and self.excuser.stopped(name, wall_s)):
            fault = Fault(name, "silent", f"silent: no heartbeat for {beat_quiet_s:.3f} s, its process is stopped",
                          wall_s, w.last_beat_s)
            return fault, False, True
        if self.excuser is not None and (beat_quiet_s > self.note_after_s or quiet_s > self.stream_note_after_s):
            self.excuser.note(name, wall_s, wall_s - max(quiet_s, beat_quiet_s))
        return fault, True, on_wall
