"""What of a tick goes on the bus: commands every tick while moving, copies at rest; status on change or period."""

from __future__ import annotations

import numpy as np

from handover_model.robots import baxter
from services.motion.outbox import Outbox
from services.motion.status import Status, TickOutput
from services.runtime.repeat import HOLD_REPEAT_S

Q = np.linspace(-0.3, 0.3, 7)


def tick(q=Q, dq=np.zeros(7), goal_id="g", state="moving", changed=False) -> TickOutput:
    return TickOutput(command_q_rad=None if q is None else np.asarray(q, dtype=float),
                      planned_q_rad=None if q is None else np.asarray(q, dtype=float),
                      command_dq_rad_s=None if q is None else np.asarray(dq, dtype=float),
                      goal_id=goal_id, status=Status(state, goal_id, "", 0.5, 0.1), status_changed=changed)


def test_no_command_before_the_first_one():
    assert Outbox(10.0).command(tick(q=None), 0.0) is None


def test_a_moving_command_goes_out_every_tick_with_its_fields():
    box = Outbox(10.0)
    dq = np.full(7, 0.2)
    for k in range(5):
        fields = box.command(tick(dq=dq), k * 0.001)
        assert fields == {"names": list(baxter.RIGHT_ARM_JOINTS), "position_rad": Q.tolist(),
                          "velocity_rad_s": dq.tolist(), "goal_id": "g"}
    assert box.command_gate.sent == 5 and box.command_gate.skipped == 0


def test_a_held_command_goes_out_on_a_change_else_one_copy_per_repeat_period():
    box = Outbox(10.0)
    assert box.command(tick(), 0.0) is not None
    assert box.command(tick(), 0.01) is None  # unchanged, too soon
    assert box.command(tick(), HOLD_REPEAT_S) is not None  # the copy that keeps the bridge fresh
    assert box.command(tick(q=Q + 1e-3), HOLD_REPEAT_S + 0.01) is not None  # moved
    assert box.command(tick(q=Q + 1e-3, goal_id="h"), HOLD_REPEAT_S + 0.02) is not None  # another goal
    assert box.command_gate.skipped == 1


def test_status_goes_out_on_a_change_else_at_its_rate():
    box = Outbox(10.0)
    assert box.status(tick(), 0.0) == {"goal_id": "g", "state": "moving", "reason": "", "progress": 0.5,
                                       "tool_speed_m_s": 0.1}
    assert box.status(tick(), 0.05) is None
    assert box.status(tick(state="reached", changed=True), 0.06) is not None
    assert box.status(tick(state="reached"), 0.1) is None  # the period counts from the last one sent
    assert box.status(tick(state="reached"), 0.16) is not None
