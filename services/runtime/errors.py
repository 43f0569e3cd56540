"""The runtime package's one exception root and its children."""

from __future__ import annotations


class ServiceError(Exception):
    """Root of every error a service reports to its user (one line, says what to check)."""


class ProfileError(ServiceError):
    """The deploy profile is missing or invalid (check the file named in the message)."""


class BusError(ServiceError):
    """The Zenoh bus could not be reached or configured (check the endpoint and the router)."""
