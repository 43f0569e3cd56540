"""Reading the measured arm from `robot/joint_state`: each received message once, malformed ones reported."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from bus_schema.messages import JointState
from handover_model.robots import baxter
from services.motion.errors import MotionError
from services.motion.joint_state import NewestArmState, arm_measurement_from
from services.runtime.logs import RateLimitedLog
from services.runtime.pubsub import Received

ARM = list(baxter.RIGHT_ARM_JOINTS)


def joint_state(names, positions, velocities=()) -> JointState:
    return JointState(seq=0, stamp_ns=0, source="bridge", names=list(names), position_rad=list(positions),
                      velocity_rad_s=list(velocities))


def test_measurement_in_arm_order_with_velocities_only_when_one_per_name():
    names = ["head_pan", *reversed(ARM)]
    m = arm_measurement_from(joint_state(names, [9.0, *range(7)], [8.0, *range(10, 17)]), 12.5)
    assert m.q_rad.tolist() == list(reversed(range(7)))
    assert m.dq_rad_s is not None and m.dq_rad_s.tolist() == list(reversed(range(10, 17)))
    assert m.at_s == 12.5
    assert arm_measurement_from(joint_state(ARM, range(7)), 0.0).dq_rad_s is None  # no velocities
    assert arm_measurement_from(joint_state(ARM, range(7), [0.0] * 3), 0.0).dq_rad_s is None  # not one per name
    with pytest.raises(MotionError, match="lacks"):
        arm_measurement_from(joint_state(ARM[:6], range(6)), 0.0)


def test_each_received_state_is_taken_once_and_a_malformed_one_is_logged(caplog):
    reader = NewestArmState(RateLimitedLog(logging.getLogger("test.motion"), 1.0))
    assert reader.take(None) is None
    first = Received(joint_state(ARM, np.linspace(0.0, 0.6, 7)), rx_monotonic=3.0)
    m = reader.take(first)
    assert m is not None and m.at_s == 3.0 and m.q_rad[-1] == pytest.approx(0.6)
    assert reader.take(first) is None  # still the newest at the next tick: nothing new
    same_content = Received(first.msg, rx_monotonic=3.01)  # a new arrival, even if equal
    assert reader.take(same_content) is not None
    with caplog.at_level(logging.WARNING, logger="test.motion"):
        assert reader.take(Received(joint_state(["right_s0"], [0.0, 1.0]), rx_monotonic=3.02)) is None
    assert "ignoring joint state: joint state has 1 names but 2 positions" in caplog.text
