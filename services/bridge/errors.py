"""The bridge package's exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class BridgeError(ServiceError):
    """Root of the bridge's errors (check the bridge config and the backend named)."""


class BridgeConfigError(BridgeError):
    """The bridge's config table is invalid (the message names the key)."""

    bad_input = True
