"""Where a plan starts: the joint state a new goal or a stop's brake starts from.

Each returns (q rad, dq rad/s, ddq rad/s²), each (n,).

A goal starts from the commanded state while the arm moves (the new plan continues the
motion smoothly), else from the measured joints at rest.

A brake, with a lagging servo (`servo_lag_s` > 0), starts from the measured joint state when
a fresh one (with velocities) is at hand, extrapolated to now: braking from the command would
first let the arm run through that lag. With a servo that tracks its commands (velocity
feed-forward, `servo_lag_s` = 0, the bridge's behaviour) it starts from the commanded state,
which is where the arm is; a measurement is up to a tick old, and braking from it would make
the arm creep back through the servo's lag.
"""

from __future__ import annotations

import numpy as np

from services.motion.commanded import CommandedState
from services.motion.errors import GoalRejected
from services.motion.ik import ArmIk
from services.motion.joint_state import ArmMeasurement

#: A joint state younger than this (s) is used as the start of a stop.
FRESH_MEASUREMENT_S = 0.05

JointStart = tuple[np.ndarray, np.ndarray, np.ndarray]


def goal_start(
    moving: bool,
    joint_state_timeout_s: float,
    ik: ArmIk,
    commanded: CommandedState,
    measured: ArmMeasurement | None,
    now_s: float,
) -> JointStart:
    """Where a new goal starts at `now_s` (monotonic s): copies of the commanded state when
    the arm is `moving` (and commanded), else the measured joints (clipped to the limits) at rest.

    Raises:
        GoalRejected: at rest with no joint state younger than `joint_state_timeout_s` s.
    """
    if moving and commanded.q_rad is not None:
        return commanded.q_rad.copy(), commanded.dq_rad_s.copy(), commanded.ddq_rad_s2.copy()
    if measured is None or now_s - measured.at_s > joint_state_timeout_s:
        raise GoalRejected(
            "no fresh joint state from the bridge"
            + ("" if measured is None else f" (last one {now_s - measured.at_s:.2f} s old)")
            + "; is handover-bridge running?"
        )
    return ik.clip_to_limits(measured.q_rad.copy()), np.zeros(len(measured.q_rad)), np.zeros(len(measured.q_rad))


def brake_start(
    servo_lag_s: float,
    ik: ArmIk,
    commanded: CommandedState,
    measured: ArmMeasurement | None,
    now_s: float,
) -> JointStart:
    """Where a brake at `now_s` (monotonic s) starts (see the module docstring). `commanded`
    must hold a command (its `q_rad` is not None); its own arrays are returned, not copies."""
    assert commanded.q_rad is not None  # a brake follows a command
    if (
        servo_lag_s > 0.0
        and measured is not None
        and measured.dq_rad_s is not None
        and now_s - measured.at_s <= FRESH_MEASUREMENT_S
    ):
        age = max(0.0, now_s - measured.at_s)
        q0 = ik.clip_to_limits(measured.q_rad + measured.dq_rad_s * age)
        return q0, measured.dq_rad_s.copy(), np.zeros(len(q0))
    return commanded.q_rad, commanded.dq_rad_s, commanded.ddq_rad_s2
