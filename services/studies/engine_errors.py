"""The engine's one exception root (`services.studies.engine`)."""

from __future__ import annotations

from services.runtime.errors import ServiceError

__all__ = ["EngineError", "EngineUsageError"]


class EngineError(ServiceError):
    """The engine could not run the tasks: a task raised (the message names its argument and
    the original error, which is also ``__cause__`` and `task_error`), the cluster could not be
    reached or started, or the checkpoint could not be written. `handover-study` exits 1."""

    bad_input = False

    def __init__(self, message: str, task_error: BaseException | None = None) -> None:
        super().__init__(message)
        self.task_error = task_error


class EngineUsageError(EngineError):
    """The engine was asked something impossible (a malformed cluster address, workers with
    an address, a checkpoint of other arguments): bad input, `handover-study` exits 2."""

    bad_input = True
