"""Exception root of the gripper package."""

from __future__ import annotations


class GripperError(Exception):
    """Any error of the gripper package: bad controller parameters, unknown controller name,
    inputs of inconsistent shape, or an analysis that has no answer for its inputs.

    The message says what to check.
    """


class GripperConfigError(GripperError):
    """The gripper service's config (profile table or command line) is invalid; the message
    names the key. `bad_input` tells the service runtime to exit with the bad-input code."""

    bad_input = True
