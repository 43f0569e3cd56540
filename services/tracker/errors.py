"""The tracker's one exception root (a `ServiceError`, so the common CLI reports it in one
line with the right exit code)."""

from services.runtime.errors import ServiceError


class TrackerError(ServiceError):
    """Root of every tracker error; the message says what to check."""


class TrackerConfigError(TrackerError):
    """The tracker configuration is invalid (check [services.tracker.config] or the CLI)."""

    bad_input = True


class ReplayFileError(TrackerError):
    """A replay file cannot be read or written (check its path and that it was recorded by
    `handover-study record`)."""

    bad_input = True


class CalibrationError(TrackerConfigError):
    """The camera's calibration file is missing or invalid (the message names the file and
    the key; docs/kinect_ros1.md#calibration says how to measure it)."""


class CameraError(TrackerError):
    """The camera path cannot run: no camera, an unreadable file or folder, the body-pose
    model's package missing (the message says what to check; docs/camera.md)."""
