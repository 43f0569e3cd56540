"""The evaluation's one exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class EvaluationError(ServiceError):
    """An evaluation could not be set up, run or reported (the message says what to check).

    `bad_input`: the user's options or files are wrong (exit 2), else the run failed (exit 1)."""

    def __init__(self, message: str, bad_input: bool = False) -> None:
        super().__init__(message)
        self.bad_input = bad_input
