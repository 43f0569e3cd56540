"""The recorder package's exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class RecorderError(ServiceError):
    """Root of the recorder's errors (check the output path or the recording named)."""

    bad_input = True
