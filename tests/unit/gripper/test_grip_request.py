"""The supervisor's grip request (open / carry / transfer) in the gripper service's core."""

from __future__ import annotations

import pytest

from services.gripper.config import GripperConfig
from services.gripper.core import GripperCore, MotionReading, WrenchReading
from services.gripper.errors import GripperError

W = 0.2 * 9.81


def feed(core: GripperCore, t: float, fy: float = W) -> None:
    core.offer_wrench(WrenchReading(force_x_n=0.0, force_y_n=fy, rx_s=t))
    core.offer_motion(MotionReading(accel_y_m_s2=0.0, slip_velocity_x_m_s=0.0, slip_velocity_y_m_s=0.0,
                                    surface_valid=True, rx_s=t))


def test_open_commands_zero_without_a_release_and_carry_holds_the_hold_force():
    core = GripperCore(GripperConfig(controller="FS1", hold_grip_force_n=12.0))
    core.set_request("open")
    for i in range(10):
        feed(core, 0.01 * i, fy=0.0)
        d = core.tick(0.01 * i)
    assert d.grip_force_n == 0.0 and d.mode == "release" and not d.released and not d.release_event
    core.set_request("carry")
    feed(core, 0.2)
    d = core.tick(0.2)
    assert d.grip_force_n == 12.0 and d.mode == "grasp" and core.steps == 0  # no controller step


def test_entering_transfer_rearms_the_controller_from_the_held_load():
    core = GripperCore(GripperConfig(controller="FS1"))
    core.set_request("carry")
    feed(core, 0.0)
    core.tick(0.0)
    core.set_request("transfer")
    feed(core, 0.01)
    d = core.tick(0.01)
    # FS1's first step starts at its fixed point for the held load: α W − F_margin = 10·1.962 − 15 N.
    assert core.steps == 1 and d.grip_force_n == pytest.approx(10 * W - 15.0, abs=1e-6)


def test_an_unknown_request_is_refused():
    with pytest.raises(GripperError, match="grip request"):
        GripperCore(GripperConfig()).set_request("squeeze")


def test_a_supervisor_state_wakes_the_gripper_only_when_its_episode_or_grip_request_changed():
    from bus_schema import topics
    from services.gripper.node import SupervisorWord

    def state(phase: str, episode_id: int, grip_request: str):
        return topics.SUPERVISOR_STATE.type(seq=0, stamp_ns=0, source="supervisor", phase=phase,
                                            episode_id=episode_id, grip_request=grip_request)

    word = SupervisorWord()
    woke = [word.changed(state(phase, episode, request)) for phase, episode, request in [
        ("idle", 0, "open"), ("idle", 0, "open"), ("locate", 1, "open"), ("pick", 1, "open"),
        ("pick", 1, "carry"), ("reach", 1, "carry"), ("transfer", 1, "transfer"), ("done", 1, "open"),
        ("done", 1, "open"), ("locate", 2, "open")]]
    assert woke == [True, False, True, False, True, False, True, True, False, True]
