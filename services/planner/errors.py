"""The planner's one exception root."""

from __future__ import annotations

from services.runtime.errors import ServiceError


class PlannerError(ServiceError):
    """Any planner failure; the message says which input to check.

    It derives from the runtime's `ServiceError` so that `run_main` reports it in one line;
    planner errors are bad input (exit code 2).
    """

    bad_input = True
