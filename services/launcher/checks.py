"""Checks `handover-up` makes on a profile before anything starts (each a one-line error, exit 2)."""

from __future__ import annotations

from services.runtime.errors import ProfileError
from services.runtime.profile import Profile


def check_niced_services_are_report_only(profile: Profile) -> None:
    """A service the supervisor watches as critical must keep nice = 0 (ProfileError otherwise).

    The supervisor makes a protective stop when a critical service's heartbeat is 0.25 s old.
    The heartbeat thread needs its process's GIL; in a niced process the main thread that holds
    it is preempted more often and for longer, so a live service falls silent that long (three
    false stops blamed the nice-5 tracker, docs/launcher_perf.md "Why these priorities"). Only services whose
    loss is reported (``watch = "report"``, e.g. the recorder) may be niced."""
    services, path = profile.services, profile.path
    supervisor = next((s for s in services if s.name == "supervisor" and s.enabled), None)
    if supervisor is None:
        return
    from services.supervisor.config import parse_config  # the supervisor owns the watch table
    from services.supervisor.errors import SupervisorConfigError

    # Only the watch table: another bad key (which the supervisor's CLI may override) must not
    # switch this check off.
    table = supervisor.config
    try:
        watch = parse_config({"watch": table["watch"]} if "watch" in table else {}).watch
    except SupervisorConfigError:
        return  # a bad watch table: the supervisor's own config check names it when it starts
    for spec in services:
        if spec.nice != 0 and spec.enabled and watch.get(spec.name, "critical") != "report":
            raise ProfileError(
                f"{path}: services.{spec.name}.nice = {spec.nice}, but the supervisor watches {spec.name} as "
                f"critical (a silent {spec.name} is a protective stop): keep nice = 0, or set "
                f"services.supervisor.config.watch.{spec.name} = \"report\"")


def clock_environment(profile: Profile, clock: str | None, job: str, services: list[str]) -> dict[str, str]:
    """The environment that puts every service of the run on its clock (`services.runtime.clock`):
    ``HANDOVER_CLOCK`` and, on the simulation clock, ``HANDOVER_CLOCK_PARTICIPANTS`` (the
    services the run starts, which the clock waits for). `clock`: ``--clock`` (None: the
    profile's).

    Raises:
        ProfileError: the simulation clock on a profile whose bridge does not simulate, or
            with the demo job (its joint commands are paced by the launcher's wall clock).
    """
    source = clock or profile.clock
    if source not in ("wall", "sim"):
        raise ProfileError(f"unknown clock {source!r}: use wall or sim")
    if source == "wall":
        return {"HANDOVER_CLOCK": "wall"}
    bridge = profile.service("bridge")
    if bridge is None or not bridge.enabled or bridge.config.get("backend", "sim") != "sim":
        raise ProfileError(f"{profile.path}: the simulation clock is owned by the bridge's simulation, and this "
                           "profile has no simulated bridge: run it with --clock wall")
    if job == "demo":
        raise ProfileError("the demo job is paced by the wall clock: run it with --clock wall")
    participants = sorted(set(services) - {"bridge", "recorder"})
    return {"HANDOVER_CLOCK": "sim", "HANDOVER_CLOCK_PARTICIPANTS": ",".join(participants)}
