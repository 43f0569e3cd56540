"""Errors of `handover-up` (`services.runtime.cli.run_main` exits 2 on those with `bad_input`)."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class LauncherError(ServiceError):
    """handover-up could not start the stack (the message names the service or setting)."""


class LauncherUsageError(LauncherError):
    """A command-line value handover-up cannot use: exit 2 before anything starts."""

    bad_input = True


class BusPortError(LauncherError):
    """The bus endpoint cannot be hosted (port in use, address not local): a usage error."""

    bad_input = True
