"""The run's bus as `handover-up` hosts it: the run's logins, the Zenoh router process on the
profile's endpoint (`services.launcher.router`) and the launcher's own session.

No failure leaves anything behind: a bus that cannot be hosted stops its router and deletes the
run's logins before the error leaves `host_bus`.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import zenoh

from services.launcher.core import LaunchOptions, bus_port_message, router_zenoh_overrides
from services.launcher.errors import BusPortError
from services.launcher.logins import RunLogins, remove_logins, start_run_logins
from services.launcher.processes import RouterProcess
from services.runtime import Profile, open_session
from services.runtime.errors import BusError
from services.runtime.zenoh_config import zenoh_config_dict


@dataclass
class HostedBus:
    """The hosted bus: the run's logins (None without per-run logins), the profile the
    launcher's own sessions use (with those logins), the router, the launcher's session."""

    logins: RunLogins | None
    bus_profile: Profile
    router: RouterProcess
    session: zenoh.Session

    def close(self) -> None:
        """Close the session, stop the router, delete the run's logins."""
        self.session.close()
        self.router.stop()
        remove_logins(self.logins)


def host_bus(profile: Profile, services: Sequence[str], options: LaunchOptions, width: int,
             on_failure: Callable[[], None]) -> HostedBus:
    """Make the run's logins for `services`, start the router (its output prefixed to `width`)
    and open the launcher's session.

    Raises:
        BusPortError: the bus cannot be hosted on the profile's endpoint (port in use, address
            not local); `on_failure` has run and nothing is left behind.
    """
    logins, bus_profile, acl = start_run_logins(profile, list(services), options.recording_dir, options.run_id,
                                                options.job)
    router: RouterProcess | None = None
    try:  # from here on, nothing may leave the run's logins behind
        router_profile = replace(bus_profile, access_control=acl,
                                 zenoh_overrides=router_zenoh_overrides(profile.zenoh_overrides))
        router = RouterProcess(json.dumps(zenoh_config_dict(router_profile, "router")), width)
        router.start()
        return HostedBus(logins, bus_profile, router, open_session(bus_profile, "client", timeout_s=5.0,
                                                                   user="launcher"))
    except BaseException as exc:
        on_failure()
        if router is not None:
            router.stop()
        remove_logins(logins)
        if not isinstance(exc, (BusError, RuntimeError)):
            raise
        raise BusPortError(bus_port_message(profile.endpoint, str(exc))) from None
