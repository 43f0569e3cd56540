"""The Baxter backend's exception root (a child of the bridge's)."""

from __future__ import annotations

from services.bridge.errors import BridgeError


class BaxterError(BridgeError):
    """Root of the Baxter backend's errors (check the robot, its ROS side and the key mapping)."""


class BaxterConfigError(BaxterError):
    """The ``[services.bridge.config.baxter]`` table is invalid (the message names the key)."""

    bad_input = True


class BaxterNotReadyError(BaxterError):
    """The robot is not there or not enabled: the backend refuses to start (the message says
    what was seen and what to do)."""


class BaxterLostError(BaxterError):
    """The robot stopped answering or was disabled while running (e-stop, cable, ROS side)."""
