"""Exceptions of the motion service: one root, messages that say what to check."""

from __future__ import annotations


class MotionError(Exception):
    """Root of every error raised by the motion service."""


class MotionConfigError(MotionError):
    """The motion configuration is invalid (check `[services.motion.config]` in the profile)."""


class IkError(MotionError):
    """Inverse kinematics could not reach the target."""


class IkInfeasibleError(IkError):
    """PlaCo's QP had no solution (constraints contradict each other at this configuration)."""


class IkNoProgressError(IkError):
    """IK stopped improving before reaching the tolerance (target out of reach or at a limit)."""

    #: Iterations spent before giving up (set where it is raised).
    iterations: int


class TrajectoryError(MotionError):
    """A trajectory could not be computed (Ruckig error or invalid path parameters)."""


class GoalRejected(MotionError):
    """A motion goal is malformed, outside the workspace or unreachable; carries the reason."""
