"""The supervisor's loop without the bus: start gate, inputs, state cadence and tick period."""

from __future__ import annotations

import pytest

from bus_schema import topics
from bus_schema.messages import HumanState, TransferTarget
from services.supervisor.config import SupervisorConfig
from services.supervisor.health import HealthWatch
from services.supervisor.supervision import (
    RESTING_PERIOD_S,
    STATE_EARLY_S,
    STATE_PERIOD_S,
    Supervision,
)
from services.supervisor.tick_io import Actions

H = {"seq": 0, "stamp_ns": 0, "source": "test"}
SERVICES = ["bridge", "gripper"]
T0 = 100.0


def supervision(**config):
    cfg = SupervisorConfig(**config)
    return Supervision(cfg, HealthWatch(SERVICES, cfg, 0.1, None), [0.0] * 7, T0)


def all_alive(sup, at_s):
    for name in SERVICES:
        sup.health.liveliness(name, True, at_s)


def test_the_tick_slows_down_only_once_the_last_episode_has_ended():
    sup = supervision(rate_hz=100.0)
    assert sup.period_s() == pytest.approx(0.01)
    sup.sequencer.finished, sup.sequencer.phase = True, "done"
    assert sup.period_s() == RESTING_PERIOD_S
    slow = supervision(rate_hz=10.0)
    slow.sequencer.finished, slow.sequencer.phase = True, "failed"
    assert slow.period_s() == pytest.approx(0.1)  # never faster than configured


def test_the_first_episode_starts_once_everyone_has_been_alive_for_the_start_delay():
    sup = supervision(start_delay_s=0.5)
    assert sup.start(T0 + 1.0) == (None, [])  # nobody alive yet, not yet overdue
    all_alive(sup, T0 + 1.0)
    assert sup.start(T0 + 1.1) == (None, [])  # alive since 1.1 s
    actions, missing = sup.start(T0 + 1.6)
    assert actions is not None and actions.state_changed and missing == []
    assert sup.sequencer.phase == "locate" and sup.sequencer.episode_id == 1
    assert sup.start(T0 + 2.0) == (None, [])  # started once


def test_services_missing_at_the_start_timeout_are_named():
    sup = supervision(start_timeout_s=5.0)
    sup.health.liveliness("bridge", True, T0)
    assert sup.start(T0 + 5.0) == (None, [])
    assert sup.start(T0 + 5.1) == (None, ["gripper"])
    assert sup.sequencer.reason == "services not alive: gripper" and sup.sequencer.phase == "idle"


def test_inputs_go_into_the_snapshot_the_target_filter_and_the_watch():
    sup = supervision(stream_timeout_s=0.2)
    all_alive(sup, T0)
    human = HumanState(**H, tracked=True, hand_position_m=(0.9, -0.26, 0.0))
    sup.take("human", topics.HUMAN.suffix, human, T0 + 0.1)
    assert sup.snapshot.human is human and sup.snapshot.human_rx_s == T0 + 0.1
    for i, x in enumerate((0.40, 0.90, 0.44)):
        target = TransferTarget(**H, position_task_m=(0.0, 0.0), position_base_m=(x, -0.26, 0.3))
        sup.take("target", topics.TRANSFER.suffix, target, T0 + 0.1 * i)
    sup.tick(T0 + 0.25)
    assert sup.snapshot.target.position_base_m[0] == pytest.approx(0.44)  # the median, not the newest
    assert sup.snapshot.target_rx_s == pytest.approx(T0 + 0.2)
    sup.take("joints", topics.JOINT_STATE.suffix, None, T0 + 0.3)
    for name in SERVICES:
        sup.health.heartbeat(name, 0, T0 + 0.5)
    (report,) = sup.health.check(T0 + 0.55)
    assert report.fault.service == "bridge" and topics.JOINT_STATE.suffix in report.fault.detail


def test_the_loop_knows_how_late_it_woke():
    sup = supervision()
    all_alive(sup, T0)
    for name in SERVICES:
        sup.health.heartbeat(name, 0, T0 + 0.2)
    assert sup.woke(T0 + 0.21) is not None  # 210 ms after the start: reported
    assert sup.woke(T0 + 0.22) is None  # 10 ms after the last wake-up


def test_the_state_goes_out_on_a_change_and_at_least_every_state_period():
    sup = supervision()
    first = sup.state_due(Actions(), T0)
    assert first == {"phase": "idle", "episode_id": 0, "reason": "waiting for the services",
                     "elapsed_s": T0, "grip_request": "open"}
    assert sup.state_due(Actions(), T0 + 0.01) is None
    assert sup.state_due(Actions(state_changed=True), T0 + 0.02) is not None  # a change: at once
    assert sup.state_due(Actions(), T0 + 0.02 + STATE_PERIOD_S - STATE_EARLY_S - 0.001) is None
    assert sup.state_due(Actions(), T0 + 0.02 + STATE_PERIOD_S - STATE_EARLY_S + 1e-9) is not None


def test_the_state_is_bounded_to_its_schema():
    sup = supervision()
    sup.sequencer.reason = "x" * 600
    state = sup.state_due(Actions(), 1e6)
    assert len(state["reason"]) == 512 and state["elapsed_s"] == 86400.0
