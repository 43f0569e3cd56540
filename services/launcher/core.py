"""Pure logic of `handover-up`: start order, shutdown order, restart decisions, commands, exit codes.

No processes are started here; `services/launcher/processes.py` does that.
"""

from __future__ import annotations

import copy
import re
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from services.runtime.errors import ProfileError
from services.runtime.profile import Profile, ServiceSpec

RECORDER = "recorder"
#: Exit codes: the job succeeded; a service or the job failed; bad input (profile, arguments,
#: port in use); interrupted by Ctrl-C/SIGTERM.
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 0, 1, 2, 130
JOBS = ("handover", "demo", "check", "none")


def start_order(specs: Sequence[ServiceSpec]) -> list[ServiceSpec]:
    """Enabled services in start order: the recorder first (it must see everything), then the
    profile's order."""
    enabled = [s for s in specs if s.enabled]
    return sorted(enabled, key=lambda s: 0 if s.name == RECORDER else 1)


def shutdown_order(specs: Sequence[ServiceSpec]) -> list[ServiceSpec]:
    """Reverse start order, except the recorder goes last (it records the shutdown)."""
    ordered = list(reversed(start_order(specs)))
    return sorted(ordered, key=lambda s: 1 if s.name == RECORDER else 0)


def job_services(specs: Sequence[ServiceSpec], job: str) -> list[ServiceSpec]:
    """The services `job` runs, in start order: every enabled one, but no supervisor for the
    ``demo`` job (the demo drives the arm itself; a supervisor running episodes would fight it)."""
    ordered = start_order(specs)
    if job == "demo":
        return [spec for spec in ordered if spec.name != "supervisor"]
    return ordered


def scene_service(specs: Sequence[ServiceSpec]) -> str:
    """The service that simulates the scene (it takes ``--receiver``): the fake Baxter when the
    services include one, else the bridge."""
    return "fake_baxter" if any(s.name == "fake_baxter" for s in specs) else "bridge"


def final_exit_code(job_code: int, failure: str | None, interrupted: bool) -> int:
    """The launcher's exit code: the job's, except that a job that succeeded while a service
    failed (`failure`) exits `EXIT_FAILED`, and one that succeeded after a stop was asked
    (`interrupted`) exits `EXIT_INTERRUPTED`."""
    if failure and job_code == EXIT_OK:
        return EXIT_FAILED
    if interrupted and job_code == EXIT_OK:
        return EXIT_INTERRUPTED
    return job_code


def bus_port_message(endpoint: str, error_text: str) -> str:
    """The one line for a bus the launcher cannot host on `endpoint`, with Zenoh's `error_text`
    without its Rust source locations (`` at /…/file.rs:61.``)."""
    reason = re.sub(r" at /\S+\.rs:\d+\.?", "", error_text).strip()
    return f"cannot host the bus on {endpoint} (is another handover-up running? use --port auto): {reason}"


@dataclass
class LaunchOptions:
    """What `handover-up` was asked to do.

    Attributes:
        job: ``handover``, ``demo``, ``check`` or ``none``.
        run_id: name of this run (recording file name).
        recording_dir: where the recorder writes.
        alive_timeout_s: every service must be alive within this time, s.
        term_timeout_s: SIGINT → SIGTERM and SIGTERM → SIGKILL delays, s.
        verbose: every service's output on the console too (else its warnings and errors).
    """

    job: str = "handover"
    run_id: str = field(default_factory=lambda: time.strftime("%Y%m%d-%H%M%S"))
    recording_dir: Path = Path("recordings")
    alive_timeout_s: float = 30.0
    term_timeout_s: float = 5.0
    receiver: str | None = None
    posture: str | None = None
    episodes: int | None = None
    seed: int | None = None
    episode_timeout_s: float = 90.0
    verbose: bool = False

    def service_args(self, name: str, scene_service: str = "bridge") -> list[str]:
        """Command-line overrides for service `name` (receiver, posture, seed → the service
        that simulates the scene: the bridge, or the fake Baxter when the profile has one;
        posture and seed also → the simulated Kinect, which renders the same receiver: the
        ``kinect`` service, or the tracker's own (``sensor = "sim"``); episodes → the
        supervisor)."""
        args: list[str] = []
        if name == scene_service and self.receiver is not None:
            args += ["--receiver", self.receiver]
        if name in (scene_service, "kinect"):
            if self.posture is not None:
                args += ["--posture", self.posture]
            if self.seed is not None:
                args += ["--seed", str(self.seed)]
        if name == "tracker":  # its simulated Kinect, when the profile renders one in the tracker
            if self.posture is not None:
                args += ["--posture", self.posture]
            if self.seed is not None:
                args += ["--kinect-seed", str(self.seed)]
        if name == "supervisor" and self.episodes is not None:
            args += ["--episodes", str(self.episodes)]
        return args


@dataclass(frozen=True)
class RestartDecision:
    """Whether to restart a service that exited, and why (one line for the log)."""

    restart: bool
    reason: str


def decide_restart(spec: ServiceSpec, restarts_so_far: int, episode_running: bool,
                   exit_code: int | None) -> RestartDecision:
    """Apply the service's restart policy to an unexpected exit.

    Safety services are never restarted while an episode runs, whatever their policy says.
    """
    how = describe_exit(exit_code)
    if spec.safety and episode_running:
        return RestartDecision(False, f"{spec.name} {how}; it is a safety service, not restarted mid-episode")
    if spec.restart != "on-failure":
        return RestartDecision(False, f"{spec.name} {how}; restart policy is 'never'")
    if restarts_so_far >= spec.max_restarts:
        return RestartDecision(False, f"{spec.name} {how}; already restarted {restarts_so_far} times "
                                      f"(max_restarts = {spec.max_restarts})")
    return RestartDecision(True, f"{spec.name} {how}; restarting ({restarts_so_far + 1}/{spec.max_restarts})")


def describe_exit(exit_code: int | None) -> str:
    """'exited with code 1', 'was killed by SIGKILL', 'is still running'."""
    import signal

    if exit_code is None:
        return "is still running"
    if exit_code < 0:
        try:
            name = signal.Signals(-exit_code).name
        except ValueError:
            name = f"signal {-exit_code}"
        return f"was killed by {name}"
    return f"exited with code {exit_code}"


def service_command(spec: ServiceSpec, profile: Profile, extra: Sequence[str] = ()) -> list[str]:
    """The command line that runs `spec` against `profile`'s bus."""
    cmd = [sys.executable, "-m", spec.module]
    if profile.path is not None:
        cmd += ["--profile", str(profile.path)]
    cmd += ["--endpoint", profile.endpoint, "--prefix", profile.prefix, *spec.args, *extra]
    return cmd


def recording_path(directory: Path, run_id: str, attempt: int = 0) -> Path:
    """Where the recorder writes this run (a restarted recorder gets a new part file)."""
    suffix = "" if attempt == 0 else f"-part{attempt + 1}"
    return directory / f"handover-{run_id}{suffix}.rrd"


def logs_dir(directory: Path, run_id: str) -> Path:
    """Where this run's log files go, beside its recording: ``<service>.log`` for every service
    (a restarted one goes on in the same file), ``launcher.log``, ``router.log``."""
    return directory / f"handover-{run_id}-logs"


#: A service's log record (`services.runtime.logs`): ``HH:MM:SS.mmm LEVEL message``, or a JSON
#: line with a ``"level"`` key.
_TEXT_RECORD = re.compile(r"^\d\d:\d\d:\d\d\.\d{3} (DEBUG|INFO|WARNING|ERROR|CRITICAL) ")
_JSON_RECORD = re.compile(r'^\{.*?"level": "(debug|info|warning|error|critical)"')
#: Levels a quiet console shows.
QUIET_LEVELS = ("WARNING", "ERROR", "CRITICAL")


def line_level(line: str) -> str | None:
    """The level of a service's output line (``INFO``, ``WARNING``, …), or None for a line that
    is not a log record (a crash's traceback, a one-line error at exit, a print)."""
    match = _TEXT_RECORD.match(line) or _JSON_RECORD.match(line)
    return match[1].upper() if match else None


def shown_when_quiet(line: str) -> bool:
    """Whether a service's output line reaches the console without ``--verbose``: its warnings
    and errors, and any non-blank line that is not a log record (a traceback, the one-line
    error of a service that exits: what a user must see when a service fails). INFO and DEBUG
    records go to the service's log file only."""
    level = line_level(line)
    return level in QUIET_LEVELS if level is not None else bool(line.strip())


def prefix_line(name: str, line: str, width: int) -> str:
    """A child's output line with its ``[name]`` prefix, names padded to `width`."""
    return f"[{name}]".ljust(width + 2) + " " + line.rstrip("\n") + "\n"


def startup_times_s(started_monotonic: dict[str, float],
                    events: Sequence[tuple[float, str, bool]]) -> dict[str, float]:
    """Seconds from each service's spawn to its first liveliness token after the spawn.

    Args:
        started_monotonic: service → monotonic time its process was started, s.
        events: (monotonic time s, service, alive) liveliness changes, in arrival order.

    Returns:
        service → spawn-to-alive time, s, for the services seen alive since their spawn.
    """
    out: dict[str, float] = {}
    for t, name, alive in events:
        started = started_monotonic.get(name)
        if alive and started is not None and name not in out and t >= started:
            out[name] = t - started
    return out


def format_startup_times(started_monotonic: dict[str, float],
                         events: Sequence[tuple[float, str, bool]]) -> str:
    """One line: every service's spawn-to-alive time, slowest first (``motion 2.10 s, …``)."""
    times = startup_times_s(started_monotonic, events)
    ordered = sorted(times.items(), key=lambda item: (-item[1], item[0]))
    return ", ".join(f"{name} {seconds:.2f} s" for name, seconds in ordered)


def router_zenoh_overrides(profile_overrides: dict[str, Any]) -> dict[str, Any]:
    """The profile's ``[bus.zenoh]`` overrides for the launcher's router session, with
    ``scouting.delay = 0`` unless the profile sets a delay itself.

    Zenoh's `open` waits `scouting.delay` (500 ms by default) for scouting answers before it
    returns; scouting is always off in this stack (multicast and gossip disabled, and the
    router connects to nobody), so that wait only delays every start-up by half a second.
    """
    merged = copy.deepcopy(profile_overrides)
    scouting = merged.setdefault("scouting", {})
    if isinstance(scouting, dict):
        scouting.setdefault("delay", 0)
    return merged


def skeleton_publishers(services: Sequence[ServiceSpec]) -> list[str]:
    """The enabled services of a profile that publish `perception/skeleton` from a simulated
    Kinect: the stand-alone ``services.sim_kinect`` (unless its config disables it) and a
    tracker that renders its own (``sensor = "sim"``)."""
    names = []
    for spec in services:
        if not spec.enabled:
            continue
        config = spec.config or {}
        if spec.module == "services.sim_kinect" and config.get("enabled", True):
            names.append(spec.name)
        elif spec.module == "services.tracker" and config.get("sensor") == "sim":
            names.append(spec.name)
    return names


def check_one_simulated_kinect(profile: Profile) -> None:
    """Refuse a profile whose skeleton would come from two simulated Kinects (two bodies, two
    noise streams on one key).

    Raises:
        ProfileError: naming both services and how to keep one.
    """
    names = skeleton_publishers(profile.services)
    if len(names) > 1:
        raise ProfileError(f"{profile.path}: {' and '.join(names)} would both render a simulated Kinect: keep one "
                           "(disable the kinect service, or set [services.tracker.config] sensor = \"bus\")")
