"""Gripper service logic (services.gripper.core): freshness, hold-never-opens, release latch,
rate handling, force → position. Expected numbers are computed by hand in each test."""

from __future__ import annotations

import numpy as np
import pytest

from services.gripper.config import GripperConfig, parse_config
from services.gripper.core import GripperCore, MotionReading, WrenchReading
from services.gripper.errors import GripperConfigError

W = 0.23 * 9.81  # the thesis's test box, N


def cfg(**kw) -> GripperConfig:
    return parse_config(kw)


def feed(core: GripperCore, t: float, fx: float = 0.0, fy: float = W, ay: float = 0.0, vx: float = 0.0, vy: float = 0.0,
         motion: bool = True):
    core.offer_wrench(WrenchReading(fx, fy, t))
    if motion:
        core.offer_motion(MotionReading(ay, vx, vy, True, t))


def test_no_data_holds_at_the_floor_and_says_why():
    core = GripperCore(cfg(controller="FS1", hold_grip_force_n=12.0))
    d = core.tick(0.0)
    assert d.mode == "hold" and not d.sensors_fresh and not d.stepped
    assert d.grip_force_n == 12.0
    assert "wrist_wrench never received" in d.reason and "object_motion never received" in d.reason
    assert d.position_m == pytest.approx(12.0 / 500.0)


def test_fs1_first_step_is_its_fixed_point_and_maps_through_the_spring():
    core = GripperCore(cfg(controller="FS1", contact_position_m=0.01))
    feed(core, 1.0)
    d = core.tick(1.0)
    rest = 10 * W - 15  # α F_sy − F_margin with F_sx = a_y = 0
    assert d.stepped and d.mode == "grasp" and d.sensors_fresh
    assert d.grip_force_n == pytest.approx(rest)
    assert d.position_m == pytest.approx(0.01 + rest / 500.0)
    # second step with a pull of 1 N: 0.13 (rest − 3) + 0.87 rest
    feed(core, 1.01, fx=1.0)
    d = core.tick(1.01)
    assert d.grip_force_n == pytest.approx(0.13 * (rest - 3.0) + 0.87 * rest)


def test_stale_wrench_holds_and_never_opens():
    core = GripperCore(cfg(controller="FS1", wrench_timeout_s=0.05, hold_grip_force_n=2.0))
    feed(core, 0.0)
    first = core.tick(0.0).grip_force_n
    # a strong pull drives the law down, then the wrench goes silent
    t = 0.0
    for _ in range(5):
        t += 0.01
        feed(core, t, fx=5.0)
        last = core.tick(t).grip_force_n
    assert 0.0 < last < first
    d = core.tick(t + 0.08)
    assert d.mode == "hold" and not d.sensors_fresh
    assert d.grip_force_n == pytest.approx(max(last, 2.0))
    assert "wrist_wrench stale for 0.080 s" in d.reason
    assert d.grip_force_n >= last  # holding never lowers the grip


@pytest.mark.parametrize("seed", range(5))
def test_random_dropouts_never_lower_the_grip_while_holding(seed):
    rng = np.random.default_rng(seed)
    core = GripperCore(cfg(controller="FS1", wrench_timeout_s=0.03, motion_timeout_s=0.03))
    t, previous = 0.0, None
    for _ in range(400):
        t += 0.01
        if rng.random() < 0.6:
            feed(core, t, fx=rng.uniform(-2, 6), fy=W + rng.normal(0, 0.5), ay=rng.normal(0, 2))
        d = core.tick(t)
        if d.mode == "hold" and previous is not None and not previous.released:
            assert d.grip_force_n >= previous.grip_force_n
        previous = d


def test_motion_required_stale_motion_holds_force_only_law_runs_without_it():
    core = GripperCore(cfg(controller="FS1"))
    feed(core, 0.0, motion=False)
    d = core.tick(0.0)
    assert d.mode == "hold" and "object_motion never received" in d.reason and "wrist_wrench" not in d.reason
    hi = GripperCore(cfg(controller="HI", require_motion=False))
    feed(hi, 0.0, motion=False)
    d = hi.tick(0.0)
    assert d.stepped and d.grip_force_n == pytest.approx(15.0)  # F_Go at the initial load


def test_undecodable_payloads_are_named_in_the_reason():
    core = GripperCore(cfg(controller="FS1"))
    core.note_rejected("wrist_wrench", 7)
    d = core.tick(0.0)
    assert d.mode == "hold" and "(7 undecodable payloads so far)" in d.reason
    with pytest.raises(Exception):
        core.note_rejected("joint_state", 1)


def test_controller_failure_holds():
    core = GripperCore(cfg(controller="HI", require_motion=False, hold_grip_force_n=9.0))
    feed(core, 0.0, fy=-1.0, motion=False)  # HI needs a downward load on its first sample
    d = core.tick(0.0)
    assert d.mode == "hold" and "controller HI failed" in d.reason and d.grip_force_n == 9.0
    # A watchdog tick with nothing new keeps saying why it holds (no hold/grasp flapping).
    again = core.tick(0.005)
    assert again.mode == "hold" and again.reason == d.reason and again.grip_force_n == 9.0
    # A good sample clears it: the controller steps and the reason goes.
    feed(core, 0.01, fy=W, motion=False)
    ok = core.tick(0.01)
    assert ok.stepped and ok.mode != "hold" and ok.reason == ""
    assert core.tick(0.012).mode != "hold"


def test_release_is_confirmed_latched_and_announced_once():
    core = GripperCore(cfg(controller="FS1", release_confirm_s=0.05))
    t = 0.0
    feed(core, t)
    core.tick(t)
    events, zero_since = [], None
    for _ in range(100):
        t += 0.01
        feed(core, t, fx=6.0, fy=0.2)  # receiver took the weight and pulls
        d = core.tick(t)
        if d.grip_force_n == 0.0 and zero_since is None:
            zero_since = t
        if d.release_event:
            events.append(t)
    assert len(events) == 1
    assert events[0] - zero_since == pytest.approx(0.05, abs=1e-9)
    # after the release the load comes back: the latch keeps the gripper open
    feed(core, t + 0.01, fy=W)
    d = core.tick(t + 0.01)
    assert d.released and d.grip_force_n == 0.0 and d.mode == "release" and not d.release_event
    core.rearm()
    feed(core, t + 0.02)
    assert core.tick(t + 0.02).grip_force_n == pytest.approx(10 * W - 15)


def test_a_single_zero_command_is_not_a_release():
    core = GripperCore(cfg(controller="FS1", release_confirm_s=0.05))
    feed(core, 0.0)
    core.tick(0.0)
    feed(core, 0.01, fx=20.0)  # one big spike
    d1 = core.tick(0.01)
    feed(core, 0.02, ay=9.0)  # falling: grip comes back
    d2 = core.tick(0.02)
    assert d2.grip_force_n > 0 and not d1.released and not d2.released


@pytest.mark.parametrize("rate_hz, input_hz, expected", [(10, 1000, 10), (25, 100, 25), (100, 100, 100),
                                                          (1000, 1000, 1000), (100, 1000, 100)])
def test_steps_at_the_configured_rate(rate_hz, input_hz, expected):
    core = GripperCore(cfg(controller="FS1", rate_hz=float(rate_hz)))
    # a node-like loop: wake on every sample and whenever next_due_s says; tick when due
    jitter = np.random.default_rng(0).uniform(-0.1, 0.1, input_hz) / input_hz
    arrivals = np.arange(input_hz) / input_hz + jitter + 1e-3
    for k, t in enumerate(arrivals):
        feed(core, t)
        end = arrivals[k + 1] if k + 1 < input_hz else t + 1.0 / input_hz
        while t < end:
            if core.due(t):
                core.tick(t)
            t = t + max(core.next_due_s(t), 1e-6)
    assert abs(core.steps - expected) <= max(1, 0.02 * expected)


def test_watchdog_ticks_without_data_and_reports_stale_sensors():
    core = GripperCore(cfg(controller="FS1", rate_hz=25.0))
    feed(core, 0.0)
    assert core.due(0.0)
    core.tick(0.0)
    assert not core.due(0.02) and core.next_due_s(0.02) == pytest.approx(0.02)
    assert core.due(0.04)
    d = core.tick(0.04)  # 40 ms without data, timeout 50 ms: still fresh, keeps the command
    assert d.mode == "grasp" and not d.stepped
    d = core.tick(0.08)
    assert d.mode == "hold"


def test_config_validation_names_the_key():
    with pytest.raises(GripperConfigError, match="rate_hz"):
        parse_config({"rate_hz": 0.5})
    with pytest.raises(GripperConfigError, match="max_grip_force_n"):
        parse_config({"max_grip_force_n": 150.0})
    with pytest.raises(GripperConfigError, match="unknown controller"):
        parse_config({"controller": "FS9"})
    with pytest.raises(GripperConfigError, match="unknown"):
        parse_config({"colour": "red"})
    with pytest.raises(GripperConfigError, match="hold_grip_force_n"):
        parse_config({"hold_grip_force_n": 50.0, "max_grip_force_n": 40.0})
    assert parse_config({}).rate_hz == 100.0


def test_commands_are_clamped_to_the_configured_maximum():
    core = GripperCore(cfg(controller="FS1", max_grip_force_n=20.0))
    feed(core, 0.0, fy=50.0)  # α F_sy − F_margin = 485 N
    assert core.tick(0.0).grip_force_n == 20.0
