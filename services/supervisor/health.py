"""The supervisor's watch of the other services' health, as its loop uses it (pure, no I/O):
what it feeds the `watchdog.Watchdog` with, what a fault means (critical or report-only,
starved or not) and when its own loop came too late to judge freshness.

Times are the local monotonic clock (s).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

from bus_schema import topics
from services.runtime.sched import MAX_EXCUSED_S
from services.supervisor.config import SupervisorConfig
from services.supervisor.watchdog import Excuser, Fault, Watchdog, judging_for_beats, resolve_heartbeat_timeout_s

#: Data streams whose silence means their service is silent (topic → owner): fixed-rate
#: streams of the services that touch the robot. The motion service's status pauses while it
#: plans a reach (tens of ms), so the motion service is judged by its heartbeat, which its
#: planner keeps sending.
WATCHED_STREAMS = {
    topics.JOINT_STATE.suffix: "bridge",
    topics.GRIPPER_STATE.suffix: "gripper",
}
#: A loop iteration this much later than the previous one means the supervisor itself was
#: starved: before calling a service silent it lets queued messages in for `SELF_STALL_SETTLE_S`.
SELF_STALL_S = 0.05
SELF_STALL_SETTLE_S = 0.01
#: A loop iteration this much late is logged even when nobody looked silent: the release
#: interrupt and every watchdog waited that long (at most one line per 5 s).
SELF_STALL_REPORT_S = 0.2


class Starvation(Excuser, Protocol):
    """An `Excuser` that learns each service's process from its heartbeats and explains a
    silence it did not excuse (`services.runtime.sched.ServiceStarvation`)."""

    def heard(self, service: str, pid: int) -> None:
        """A heartbeat of `service` said it runs as `pid` (0: not said)."""

    def explain(self, service: str) -> str:
        """Why a silence of `service` was not excused (one line)."""


@dataclass(frozen=True)
class FaultReport:
    """A new fault and what it means.

    Attributes:
        fault: the watchdog's fault.
        critical: True when the service is critical (a protective stop), False when
            report-only.
        starvation: why a silence was not excused as starvation (``n/a`` for a lost
            service, or where starvation is not judged).
    """

    fault: Fault
    critical: bool
    starvation: str

    def log_fields(self) -> dict[str, Any]:
        """The fields of the ``service fault`` log line."""
        f = self.fault
        return {"service": f.service, "what": f.what, "detail": f.detail, "critical": self.critical,
                "notice_latency_s": round(f.noticed_s - f.since_s, 4), "starvation": self.starvation}


@dataclass(frozen=True)
class Stall:
    """The supervisor's own loop woke `late_s` (s) after its previous wake-up.

    Attributes:
        late_s: time since the previous wake-up, s.
        settle: a service looks silent: take queued messages in (`SELF_STALL_SETTLE_S`)
            before judging freshness.
    """

    late_s: float
    settle: bool

    @property
    def late_ms(self) -> int:
        return round(self.late_s * 1e3)

    def message(self) -> str:
        """The ``stall`` log line."""
        if self.settle:
            return (f"supervisor loop was {self.late_s * 1e3:.0f} ms late: "
                    "taking queued messages in before judging freshness")
        return f"supervisor loop was {self.late_s * 1e3:.0f} ms late (starved of CPU?); no service looked silent"


class HealthWatch:
    """The `Watchdog` over `services`, set up from the supervisor's settings.

    Args:
        services: the services to watch (every service of the profile but the supervisor).
        config: supervisor settings (time-outs, the watch table: critical or report).
        beat_period_s: the heartbeat period of the profile, s.
        starvation: judges a silence as starvation (one host only; None: never excused).

    Raises:
        SupervisorConfigError: a heartbeat time-out shorter than one beat period and 50 ms.
    """

    def __init__(self, services: list[str], config: SupervisorConfig, beat_period_s: float,
                 starvation: Starvation | None) -> None:
        self.config = config
        self.starvation = starvation
        heartbeat_timeout_s = resolve_heartbeat_timeout_s(config.heartbeat_timeout_s, beat_period_s)
        self.watchdog = Watchdog(services, heartbeat_timeout_s, config.stream_timeout_s,
                                 {s: o for s, o in WATCHED_STREAMS.items() if o in services},
                                 {name: config.report_heartbeat_timeout_s for name in services
                                  if config.watch.get(name) == "report"},
                                 excuser=starvation, max_excused_s=MAX_EXCUSED_S, **judging_for_beats(beat_period_s))

    # ------------------------------------------------------------------ inputs
    def liveliness(self, service: str, alive: bool, at_s: float) -> None:
        self.watchdog.liveliness(service, alive, at_s)

    def heartbeat(self, service: str, pid: int, rx_s: float) -> None:
        """A heartbeat of `service` (its process `pid`) received at `rx_s` (s)."""
        self.watchdog.heartbeat(service, rx_s)
        if self.starvation is not None:
            self.starvation.heard(service, pid)

    def stream(self, suffix: str, rx_s: float) -> None:
        self.watchdog.stream(suffix, rx_s)

    # ------------------------------------------------------------------ judging
    def stall(self, late_s: float, now_s: float) -> Stall | None:
        """The supervisor's loop woke `late_s` (s) after its previous wake-up: a `Stall` when
        that is late enough to act on (`SELF_STALL_S` with a service looking silent) or to
        say (`SELF_STALL_REPORT_S`), else None."""
        if late_s > SELF_STALL_S and any(f.what == "silent" for f in self.watchdog.pending(now_s)):
            return Stall(late_s, settle=True)
        if late_s > SELF_STALL_REPORT_S:
            return Stall(late_s, settle=False)
        return None

    def check(self, now_s: float, wall_now_s: float | None = None) -> list[FaultReport]:
        """The new faults at `now_s` (s), each with what it means (see `excused` for the
        silences excused as starvation). `wall_now_s`: the local monotonic time on the
        simulation clock (heartbeats are timed on it; `Watchdog.check`)."""
        reports = []
        for fault in self.watchdog.check(now_s, wall_now_s):
            critical = self.config.watch.get(fault.service, "critical") == "critical"
            starved = (self.starvation.explain(fault.service)
                       if self.starvation is not None and fault.what == "silent" else "n/a")
            reports.append(FaultReport(fault, critical, starved))
        return reports

    @property
    def excused(self) -> list[tuple[str, str]]:
        """(service, why) of the silences excused at the last `check`."""
        return self.watchdog.excused
