"""The supervisor's exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class SupervisorError(ServiceError):
    """Anything the supervisor cannot do; the message says what to check."""


class SupervisorConfigError(SupervisorError):
    """`[services.supervisor.config]` is invalid (the message names the key)."""

    bad_input = True
