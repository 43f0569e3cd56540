"""Safety invariants and latencies of one fault run, computed from what the test recorded.

Pure functions over a `RunRecord` (no I/O), so they are unit-tested on hand-made records.
Times are the test process's monotonic clock (s). The latencies and the motion checks use the
senders' stamps (the bus header's wall clock of this one host), converted with the fault's
wall/monotonic pair, not when this process happened to receive a message: starved of CPU it
can receive late, and that is not the stack's delay. The launcher's log lines carry no stamp
and count at receive time.

Invariants (issue 8, "Must show"):

1. **not dropped**: sim truth `dropped` is never true.
2. **no motion after a stop**: after a protective stop, once the arm is at rest
   (all |v| < `REST_SPEED_RAD_S`), no joint state shows a speed above `MOVE_SPEED_RAD_S`
   until the end of the run; after the release stop the same holds until the supervisor
   sends the retract goal (the retract after the release dwell is allowed). An arm that
   never comes to rest breaks it too: joint states still coming `REST_DEADLINE_S` after the
   stop without the arm having settled (no joint states at all, e.g. the bridge killed, is
   no evidence either way).
3. **reported**: a lost or frozen service is named in the episode summary (faults or
   reason) or in the launcher's exit line.
4. **clear exit**: a critical service's fault ends `handover-up` with exit 1 and a reason on
   its `exit 1:` line; a report-only service (the recorder) lets it end with 0.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

#: The arm counts as at rest below this joint speed (the supervisor's `rest_speed_rad_s`).
REST_SPEED_RAD_S = 0.01
#: After the arm came to rest under a stop, a joint faster than this is a violation.
MOVE_SPEED_RAD_S = 0.02
#: After a stop, joint states this long after it with the arm never at rest are a violation
#: (braking from the arm's top speed takes about 50 ms; the margin covers a starved bridge).
REST_DEADLINE_S = 0.5
#: Services whose loss the supervisor only reports (deploy/sim.toml `watch`).
REPORT_ONLY = frozenset({"recorder"})
SERVICE_KINDS = ("kill", "freeze")
TOPIC_KINDS = ("delay", "drop", "flood")


@dataclass
class FaultPlan:
    """One fault to inject.

    Attributes:
        kind: ``kill`` (SIGKILL), ``freeze`` (SIGSTOP, SIGCONT after `duration_s`),
            ``delay``/``drop`` (the service's publications on `topic`, via
            `HANDOVER_FAULTS`, armed at the phase), ``flood`` (garbage on `topic` from the
            test for `duration_s`).
        service: the service the fault hits (for flood: the topic's publisher, for naming).
        phase: inject when the supervisor enters this phase.
        topic: topic suffix (delay, drop, flood).
        value: delay (s) or drop probability.
        duration_s: freeze length, flood length, or how long a delay/drop stays armed
            (0: to the end of the run).
        offset_s: wait this long after the phase entry before injecting.
        rate_hz: flood rate (messages per second).
    """

    kind: str
    service: str
    phase: str = "transfer"
    topic: str | None = None
    value: float = 0.0
    duration_s: float = 0.0
    offset_s: float = 0.0
    rate_hz: float = 1000.0

    @property
    def label(self) -> str:
        what = f"{self.service}" + (f" {self.topic}" if self.topic else "")
        extra = f" {self.value:g}" if self.kind in ("delay", "drop") else ""
        return f"{self.kind}{extra} {what} @ {self.phase}"

    @property
    def critical(self) -> bool:
        """A kill or freeze of a service the supervisor must protective-stop for."""
        return self.kind in SERVICE_KINDS and self.service not in REPORT_ONLY


@dataclass
class Injection:
    """What was injected and when (test monotonic and wall clock, s)."""

    plan: FaultPlan
    at_s: float
    at_wall_s: float
    phase_seen_s: float
    pid: int | None = None
    ended_s: float | None = None
    sent: int = 0


@dataclass
class RunRecord:
    """Everything one run recorded (lists of (rx time, message) in arrival order)."""

    receiver: str
    injections: list[Injection] = field(default_factory=list)
    states: list[tuple[float, Any]] = field(default_factory=list)
    summaries: list[tuple[float, Any]] = field(default_factory=list)
    truth: list[tuple[float, Any]] = field(default_factory=list)
    joints: list[tuple[float, Any]] = field(default_factory=list)
    stops: list[tuple[float, Any]] = field(default_factory=list)
    goals: list[tuple[float, Any]] = field(default_factory=list)
    releases: list[tuple[float, Any]] = field(default_factory=list)
    targets: list[tuple[float, Any]] = field(default_factory=list)
    lines: list[tuple[float, str]] = field(default_factory=list)
    exit_code: int | None = None
    exit_line: str = ""
    phases_missed: list[str] = field(default_factory=list)


@dataclass
class Verdict:
    """Invariant results and latencies of one run."""

    violations: list[str]
    detection_s: dict[str, float]
    stop_s: dict[str, float]
    outcome: str
    exit_code: int | None
    exit_line: str

    @property
    def ok(self) -> bool:
        return not self.violations


def _max_speed(msg: Any) -> float:
    v = msg.velocity_rad_s
    return max((abs(x) for x in v), default=0.0)


#: Braking is done at the first of this many consecutive joint states at rest (30 ms at
#: 100 Hz): one sample at a velocity zero crossing is not "at rest".
REST_SAMPLES = 3


def first_rest_after(joints: list[tuple[float, Any]], t0_s: float) -> float | None:
    """Receive time of the first of `REST_SAMPLES` consecutive joint states at or after
    `t0_s` with the arm at rest (None if the arm never settled, or no joint state came)."""
    run: list[float] = []
    for t, msg in joints:
        if t < t0_s:
            continue
        if _max_speed(msg) < REST_SPEED_RAD_S:
            run.append(t)
            if len(run) >= REST_SAMPLES:
                return run[0]
        else:
            run = []
    return None


def stamp_s(msg: Any) -> float:
    """A message's sender stamp (`stamp_ns`, wall clock of this host), s."""
    return msg.stamp_ns / 1e9


def by_stamp(pairs: list[tuple[float, Any]]) -> list[tuple[float, Any]]:
    """(receive time, message) pairs re-keyed by the sender's stamp, in stamp order."""
    return sorted(((stamp_s(m), m) for _t, m in pairs), key=lambda p: p[0])


def motion_between(joints: list[tuple[float, Any]], start_s: float, end_s: float) -> tuple[float, float] | None:
    """The fastest joint state in [start_s, end_s) above `MOVE_SPEED_RAD_S`: (time, speed)."""
    worst = None
    for t, msg in joints:
        if start_s <= t < end_s:
            speed = _max_speed(msg)
            if speed > MOVE_SPEED_RAD_S and (worst is None or speed > worst[1]):
                worst = (t, speed)
    return worst


def never_settled(joints: list[tuple[float, Any]], stop_s: float, until_s: float) -> str | None:
    """Why the arm counts as never at rest after a stop at `stop_s` (None: no evidence):
    joint states in [stop_s + `REST_DEADLINE_S`, `until_s`) came, one of them moving, and none
    of the states after the stop began `REST_SAMPLES` at rest before `until_s`. Fewer than
    `REST_SAMPLES` late states all at rest are rest (a bridge frozen through the stop that sent
    one state, at rest, before it shut down)."""
    late = [(t, m) for t, m in joints if stop_s + REST_DEADLINE_S <= t < until_s]
    if not late or all(_max_speed(m) < REST_SPEED_RAD_S for _t, m in late):
        return None  # no evidence, or every late state at rest (a bridge thawed only to shut down)
    rest = first_rest_after(joints, stop_s)
    if rest is not None and rest < until_s:
        return None
    t, msg = late[-1]
    return (f"{len(late)} joint states {REST_DEADLINE_S:.1f} s or more after the stop, the last at t={t:.3f} "
            f"moving at {_max_speed(msg):.3f} rad/s (sender clock)")


_LOG_STAMP = re.compile(r"^\[(?P<name>[a-z_]+)\s*\] (?P<h>\d\d):(?P<m>\d\d):(?P<s>\d\d\.\d+) ")


def log_time_to_monotonic(line: str, ref_wall_s: float, ref_mono_s: float) -> float | None:
    """A service log line's wall-clock stamp (HH:MM:SS.mmm, local) as test monotonic time."""
    m = _LOG_STAMP.match(line)
    if not m:
        return None
    import time as _time

    lt = _time.localtime(ref_wall_s)
    day_start = ref_wall_s - (lt.tm_hour * 3600 + lt.tm_min * 60 + lt.tm_sec + (ref_wall_s % 1.0))
    wall = day_start + int(m["h"]) * 3600 + int(m["m"]) * 60 + float(m["s"])
    return ref_mono_s + (wall - ref_wall_s)


def sent_at(inj: Injection, msg: Any) -> float:
    """When `msg` was sent by its stamp, on the test's monotonic clock (via the injection's
    wall/monotonic pair)."""
    return inj.at_s + (stamp_s(msg) - inj.at_wall_s)


def detection_time(rec: RunRecord, inj: Injection) -> float | None:
    """When the stack noticed the fault (test monotonic s): the first supervisor state sent
    after the injection whose reason names the service, the supervisor's own ``service fault
    service=<name>`` log line (report-only services change no state), or the launcher's
    notice: the protective stop it sent naming the service (by its stamp; the bridge's stop on
    the supervisor's lost token counts the same), or its ``FAILURE:`` line (by when this test
    read it: later than the launcher wrote it when this process waits for a CPU)."""
    service = inj.plan.service
    candidates = []
    for _stamp, msg in by_stamp(rec.stops):
        t = sent_at(inj, msg)
        if t >= inj.at_s and msg.protective and msg.source in ("launcher", "bridge") and service in msg.reason:
            candidates.append(t)
            break
    for _stamp, msg in by_stamp(rec.states):
        t = sent_at(inj, msg)
        if t >= inj.at_s and service in msg.reason and (msg.phase == "protective_stop" or "silent" in msg.reason
                                                         or "lost" in msg.reason):
            candidates.append(t)
            break
    for rx, line in rec.lines:
        if rx >= inj.at_s and line.startswith("[launcher] FAILURE:") and service in line:
            candidates.append(rx)  # the launcher saw the child die (e.g. the supervisor itself)
            break
    for _rx, line in rec.lines:
        if line.startswith("[supervisor]") and f"service fault service={service} " in line:
            t = log_time_to_monotonic(line, inj.at_wall_s, inj.at_s)
            if t is not None and t >= inj.at_s - 0.002:
                candidates.append(max(t, inj.at_s))
                break
    return min(candidates) if candidates else None


def first_protective_stop(rec: RunRecord, inj: Injection) -> float | None:
    """When the first protective stop after the injection was sent (test monotonic s)."""
    for _stamp, msg in by_stamp(rec.stops):
        t = sent_at(inj, msg)
        if t >= inj.at_s and msg.protective:
            return t
    return None


def judge(rec: RunRecord, strict_exit: bool = True) -> Verdict:
    """Check the invariants and measure the latencies of one run (see the module docstring).

    Args:
        strict_exit: a run with only tolerated faults (delay, drop, flood, the recorder)
            must exit 0; when False, a protective stop naming a service is accepted too (a
            heavy delay or drop may silence a stream: that is a detection, not a violation).
    """
    violations: list[str] = []
    detection: dict[str, float] = {}
    stop: dict[str, float] = {}
    summary = rec.summaries[-1][1] if rec.summaries else None
    outcome = summary.outcome if summary is not None else "none"

    # 1. never dropped
    drops = [t for t, m in rec.truth if m.dropped]
    if drops:
        violations.append(f"object dropped (sim truth) at t={drops[0]:.3f}")
    if not rec.truth:
        violations.append("no sim truth recorded")

    # 2. no motion after a protective stop (to the end) or a release stop (to the retract goal),
    # judged by the senders' stamps (one host clock): when the bridge measured the arm and when
    # the supervisor sent its stop and goals. This test process receives different keys on
    # different threads, so under load its receive order can put a joint state of the retract
    # before the retract goal that caused it.
    end_s = math.inf
    joints = by_stamp(rec.joints)
    prot = [m for _t, m in rec.stops if m.protective]
    if prot:
        t_prot = min(stamp_s(m) for m in prot)
        rest = first_rest_after(joints, t_prot)
        if rest is not None:
            moved = motion_between(joints, rest, end_s)
            if moved:
                violations.append(f"arm moved after the protective stop: {moved[1]:.3f} rad/s at "
                                  f"t={moved[0]:.3f} (at rest since {rest:.3f}, sender clock)")
        else:
            unsettled = never_settled(joints, t_prot, end_s)
            if unsettled:
                violations.append(f"arm never came to rest after the protective stop: {unsettled}")
    release_stops = [stamp_s(m) for _t, m in rec.stops if not m.protective and m.reason == "release"]
    if release_stops:
        t_rel = min(release_stops)
        retract_goals = [stamp_s(g) for _t, g in rec.goals if stamp_s(g) >= t_rel and g.kind == "retract"]
        until = min(retract_goals) if retract_goals else end_s
        rest = first_rest_after(joints, t_rel)
        if rest is not None and rest < until:
            moved = motion_between(joints, rest, until)
            if moved:
                violations.append(f"arm moved after the release stop before the retract: {moved[1]:.3f} rad/s "
                                  f"at t={moved[0]:.3f} (sender clock)")
        else:
            unsettled = never_settled(joints, t_rel, until)
            if unsettled:
                violations.append(f"arm did not come to rest after the release stop: {unsettled}")

    # 3./4. reported, clear exit; latencies
    for inj in rec.injections:
        plan = inj.plan
        if plan.kind in SERVICE_KINDS:
            t_detect = detection_time(rec, inj)
            if t_detect is not None:
                detection[plan.label] = t_detect - inj.at_s
            named_in_summary = summary is not None and (
                plan.service in summary.reason or any(plan.service in f for f in summary.faults))
            named = named_in_summary or plan.service in rec.exit_line
            if not named:
                violations.append(f"{plan.label}: the service is not named in the summary or the exit line "
                                  f"(summary: {summary.reason if summary else 'none'!r}; exit: {rec.exit_line!r})")
            if plan.critical:
                if rec.exit_code != 1:
                    violations.append(f"{plan.label}: launcher exit {rec.exit_code}, expected 1")
                elif plan.service not in rec.exit_line and "protective" not in rec.exit_line:
                    violations.append(f"{plan.label}: exit line gives no clear reason: {rec.exit_line!r}")
                t_stop = first_protective_stop(rec, inj)
                if t_stop is None and plan.service != "supervisor":
                    violations.append(f"{plan.label}: no protective motion/stop after the fault")
                if t_stop is not None:
                    sent_joints = sorted(((sent_at(inj, m), m) for _t, m in rec.joints), key=lambda p: p[0])
                    rest = first_rest_after(sent_joints, t_stop)
                    if rest is not None:
                        stop[plan.label] = max(t_stop, rest) - inj.at_s
    critical = [i for i in rec.injections if i.plan.critical]
    if not critical and rec.injections:  # nothing injected (phase never reached): no exit rule
        named_stop = summary is not None and summary.outcome == "protective_stop" and ": " in summary.reason
        if rec.exit_code != 0 and (strict_exit or not named_stop or rec.exit_code != 1):
            violations.append(f"only tolerated faults ({', '.join(i.plan.label for i in rec.injections)}), "
                              f"but the launcher exited {rec.exit_code}: {rec.exit_line!r}")
    return Verdict(violations, detection, stop, outcome, rec.exit_code, rec.exit_line)
