"""The Franka backend's exception root (a child of the bridge's)."""

from __future__ import annotations

from services.bridge.errors import BridgeError


class FrankaError(BridgeError):
    """Root of the Franka backend's errors (check the robot, its FCI network link and Desk)."""


class FrankaConfigError(FrankaError):
    """The ``[services.bridge.config.franka]`` table is invalid (the message names the key)."""

    bad_input = True


class FrankaNotReadyError(FrankaError):
    """The robot cannot be reached or is not ready to move: the backend refuses to start."""


class FrankaLostError(FrankaError):
    """The robot stopped answering while running (network, power, the robot's own stop)."""


class FrankaControlError(FrankaError):
    """The robot aborted a motion (a reflex, a limit, a protocol error): libfranka's
    ``ControlException``; the message names the robot's errors."""
