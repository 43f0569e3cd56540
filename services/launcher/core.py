"""Pure logic of `handover-up`: start order, shutdown order, restart decisions, commands.

No processes are started here; `services/launcher/processes.py` does that.
"""

from __future__ import annotations

import copy
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from services.runtime.profile import Profile, ServiceSpec

RECORDER = "recorder"


def start_order(specs: Sequence[ServiceSpec]) -> list[ServiceSpec]:
    """Enabled services in start order: the recorder first (it must see everything), then the
    profile's order."""
    enabled = [s for s in specs if s.enabled]
    return sorted(enabled, key=lambda s: 0 if s.name == RECORDER else 1)


def shutdown_order(specs: Sequence[ServiceSpec]) -> list[ServiceSpec]:
    """Reverse start order, except the recorder goes last (it records the shutdown)."""
    ordered = list(reversed(start_order(specs)))
    return sorted(ordered, key=lambda s: 1 if s.name == RECORDER else 0)


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
