"""Opening a Zenoh session with the profile's loopback-only config (every session of the stack)."""

from __future__ import annotations

import time

import zenoh

from services.runtime.errors import BusError
from services.runtime.profile import Profile
from services.runtime.zenoh_config import zenoh_config


def open_session(profile: Profile, mode: str = "client", timeout_s: float = 10.0,
                 user: str | None = None) -> zenoh.Session:
    """Open a Zenoh session with the profile's loopback-only config, retrying until the
    router answers or `timeout_s` passes. `user` names the credentials a client presents
    when the profile has ``[bus.auth]`` (services pass their own name).

    Raises:
        BusError: the router at the profile's endpoint did not answer in time.
    """
    deadline = time.monotonic() + timeout_s
    last_error: Exception | None = None
    while True:
        try:
            return zenoh.open(zenoh_config(profile, mode, user))  # type: ignore[arg-type]
        except zenoh.ZError as exc:
            last_error = exc
        if time.monotonic() >= deadline:
            raise BusError(
                f"could not reach the Zenoh router at {profile.endpoint} within {timeout_s:.1f} s "
                f"(is handover-up or a router running there?): {last_error}"
            )
        time.sleep(0.05)
