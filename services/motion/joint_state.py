"""The measured right-arm joint state, read from the bridge's `robot/joint_state` messages."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from bus_schema.messages import JointState
from handover_model import robots
from services.motion.errors import MotionError
from services.runtime.logs import RateLimitedLog
from services.runtime.pubsub import Received


@dataclass(frozen=True)
class ArmMeasurement:
    """A measured right-arm joint state.

    Attributes:
        q_rad: joint positions (n,), rad, in the arm's joint order.
        dq_rad_s: joint velocities (n,), rad/s, or None when the message carried none.
        at_s: local receive time, monotonic s.
    """

    q_rad: np.ndarray
    dq_rad_s: np.ndarray | None
    at_s: float


def arm_positions_from(names: Sequence[str], positions: Sequence[float]) -> np.ndarray:
    """The arm's joint positions (n,) in the active description's order from a named joint list.

    Raises:
        MotionError: a right-arm joint is missing or the lists differ in length.
    """
    if len(names) != len(positions):
        raise MotionError(
            f"joint state has {len(names)} names but {len(positions)} positions"
        )
    index = {n: i for i, n in enumerate(names)}
    joints = robots.active().joints
    missing = [n for n in joints if n not in index]
    if missing:
        raise MotionError(f"joint state lacks right-arm joint(s) {missing}")
    return np.array([positions[index[n]] for n in joints], dtype=float)


def arm_measurement_from(msg: JointState, received_at_s: float) -> ArmMeasurement:
    """The arm's joints from a `JointState` received at `received_at_s` (monotonic s);
    velocities only when the message has one per name.

    Raises:
        MotionError: a right-arm joint is missing or the lists differ in length.
    """
    q = arm_positions_from(msg.names, msg.position_rad)
    dq = None
    if len(msg.velocity_rad_s) == len(msg.names):
        dq = arm_positions_from(msg.names, msg.velocity_rad_s)
    return ArmMeasurement(q, dq, received_at_s)


class NewestArmState:
    """Gives each received joint state to the controller once: the node reads its
    subscription's newest message at every tick, and the same message may still be the
    newest at the next one.

    Args:
        bad_state_log: where a malformed joint state is reported (rate-limited).
    """

    def __init__(self, bad_state_log: RateLimitedLog) -> None:
        self._bad_state_log = bad_state_log
        self._last: Received[JointState] | None = None

    def take(self, latest: Received[JointState] | None) -> ArmMeasurement | None:
        """The measurement in `latest` if it is new and well formed, else None."""
        if latest is None or latest is self._last:
            return None
        self._last = latest
        try:
            return arm_measurement_from(latest.msg, latest.rx_monotonic)
        except MotionError as exc:
            self._bad_state_log.warning("joint_state", f"ignoring joint state: {exc}")
            return None
