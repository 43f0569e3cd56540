"""Gripper actuators other than the thesis's: the force rate and the position-loop rate are
what was asked (measured on the plant), and the sensors and controllers follow the loop."""

from __future__ import annotations

import functools
import logging
from dataclasses import replace

import numpy as np
import pytest

from robot_sim.contact.batch import run_batch
from robot_sim.contact.config import ContactSimError, GripperParams, SimConfig
from robot_sim.contact.controllers import ConstantGrip
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import absent

from tests.unit.contact.helpers import quiet_config


def _grip_after_step(cfg: SimConfig, before_n: float, after_n: float, steps: int):
    """Grip force (N) per plant step after the command jumps from `before_n` to `after_n` at
    a loop tick (no receiver, object held)."""
    plant = ContactPlant(cfg, absent(), seed=0, initial_grip_force_n=before_n)
    out = []
    for _ in range(steps):
        plant.step(after_n)
        out.append(plant.actuator.spring_force_n())
    return np.array(out)


@pytest.mark.parametrize("rate_n_s, loop_hz", [(50.0, 25.0), (500.0, 250.0), (500.0, 25.0), (150.0, 100.0)])
def test_force_slope_and_latch_interval_are_what_was_asked(rate_n_s, loop_hz):
    cfg = quiet_config(duration_s=2.0).with_gripper_rates(rate_n_s, loop_hz)
    assert cfg.gripper.force_rate_n_per_s == pytest.approx(rate_n_s, rel=1e-12)
    # Force slope: a 100 N step rises at the speed limit, never faster.
    fg = _grip_after_step(cfg, 10.0, 110.0, 1000)
    slope = np.diff(fg) / cfg.dt_s
    assert slope.max() == pytest.approx(rate_n_s, rel=1e-9)
    assert np.mean(np.isclose(slope[:50], rate_n_s, rtol=1e-9)) > 0.9  # at the limit from the start
    # Latch interval: a command that changes at every plant step is taken every loop period.
    plant = ContactPlant(cfg, absent(), seed=0, initial_grip_force_n=10.0)
    latched = []
    for k in range(400):
        target = plant.actuator.target_m
        plant.step(10.0 + 0.01 * k)
        if plant.actuator.target_m != target:
            latched.append(k)
    intervals_s = np.diff(latched) * cfg.dt_s
    np.testing.assert_allclose(intervals_s, 1.0 / loop_hz, rtol=1e-9)
    # The F/T sensor and the controllers run at the loop's rate when it is above 100 Hz.
    assert cfg.control_period_s == pytest.approx(1.0 / max(100.0, loop_hz))
    assert cfg.sensors.ft_rate_hz == max(100.0, loop_hz)
    assert cfg.sensors.optical_report_rate_hz == 100.0


def test_fast_gripper_reaches_a_new_force_sooner_but_keeps_the_finger_lag():
    slow = quiet_config(duration_s=1.0)
    fast = slow.with_gripper_rates(500.0, 250.0)
    rise = {}
    for name, cfg in (("slow", slow), ("fast", fast)):
        fg = _grip_after_step(cfg, 5.0, 25.0, 900)
        rise[name] = [(np.flatnonzero(fg >= level)[0] + 1) * cfg.dt_s for level in (23.0, 24.9)]  # 90 %, 99.5 %
    assert rise["slow"][0] >= 18.0 / 50.0  # 18 N at 50 N/s
    assert rise["fast"][0] < 0.06 and rise["fast"][0] < rise["slow"][0] / 6  # 500 N/s, then the 20 ms lag
    # The last 0.1 N follows the 20 ms first-order lag (the same in every class): ln(200) · 20 ms ≈ 106 ms.
    assert 0.09 < rise["fast"][1] < 0.13


def test_the_default_setup_is_the_slow_gripper_and_bad_rates_are_refused():
    base = SimConfig()
    assert base.with_gripper_rates(50.0, 25.0) == base
    assert base.gripper.force_rate_n_per_s == 50.0 and base.control_period_s == 0.01
    assert GripperParams().with_rates(500.0, 250.0).speed_limit_m_s == pytest.approx(1.0)
    with pytest.raises(ContactSimError, match="whole number of plant steps"):
        base.with_gripper_rates(500.0, 150.0)  # 6.67 steps of 1 ms
    with pytest.raises(ContactSimError, match="force rate"):
        base.with_gripper_rates(0.0, 25.0)
    with pytest.raises(ContactSimError):
        replace(base, dt_s=0.005).with_gripper_rates(500.0, 250.0)  # faster than the plant step


def test_batch_runner_warns_when_the_controller_is_slower_than_a_fast_loop(caplog):
    cfg = quiet_config(duration_s=0.05).with_gripper_rates(500.0, 250.0)
    with caplog.at_level(logging.WARNING, logger="robot_sim.contact.batch"):
        run_batch(cfg, "drag", 2, functools.partial(ConstantGrip, 10.0, period_s=0.01), progress=False)
    assert "latches every 0.004 s" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="robot_sim.contact.batch"):
        res = run_batch(cfg, "drag", 2, functools.partial(ConstantGrip, 10.0, period_s=cfg.control_period_s),
                        progress=False)
    assert caplog.text == "" and len(res.outcome) == 2
