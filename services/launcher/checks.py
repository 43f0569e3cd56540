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
