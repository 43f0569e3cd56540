"""The simulated Kinect's exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class KinectError(ServiceError):
    """Root of the simulated Kinect's errors (check `[services.kinect.config]`)."""


class KinectConfigError(KinectError):
    """The Kinect's config table is invalid (the message names the key)."""

    bad_input = True
