"""One bridge tick without the bus (`ArmLoop`): commands through the gate, stops and goals in
arrival order, a new episode, the grip command, a stall, the joint state and `sim/truth`'s
repeats."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bus_schema import topics
from handover_model.robots.baxter import RIGHT_ARM_HOME_RAD
from services.bridge.arm_loop import STALL_PERIODS, TRUTH_REPEAT_S, ArmLoop, Inbox
from services.bridge.backend import SimBackend
from services.bridge.config import parse_config
from services.runtime.pubsub import Received

HOME = np.array(RIGHT_ARM_HOME_RAD)
CONFIG = parse_config({})  # 100 Hz, 0.2 s command time-out, 40 rad/s² braking
PERIOD_S = 1.0 / CONFIG.rate_hz


class FakeQueue:
    """A subscription's `drain()`, fed by the test."""

    def __init__(self) -> None:
        self.queued: list[Received] = []

    def put(self, rx_s: float, **fields) -> Received:
        rx = Received(SimpleNamespace(**fields), rx_s)
        self.queued.append(rx)
        return rx

    def drain(self) -> list[Received]:
        out, self.queued = self.queued, []
        return out


class RecordingBackend(SimBackend):
    """The sim arm, recording the calls the bridge makes that the tests look at."""

    def __init__(self) -> None:
        super().__init__(initial_position_rad=HOME)
        self.calls: list[tuple] = []
        self.truth: list[dict] = []
        self.episodes = 0
        self.told_running: list[bool] = []
        self._catching_up = False

    def catch_up(self, gap_s: float) -> None:
        self.calls.append(("catch_up", gap_s))
        self._catching_up = True  # its own steps are not the bridge's
        super().catch_up(gap_s)
        self._catching_up = False

    def step(self, dt_s: float) -> None:
        if not self._catching_up:
            self.calls.append(("step", dt_s))
        super().step(dt_s)

    def gripper_command(self, grip_force_n: float) -> None:
        self.calls.append(("grip", grip_force_n))

    def new_episode(self) -> None:
        self.episodes += 1

    def episode_running(self, running: bool) -> None:
        self.told_running.append(running)

    def publish_extras(self, publish) -> None:
        publish(topics.SIM_TRUTH.suffix, dict(self.truth[-1]))
        publish("sensors/other", {"n": len(self.truth)})


def _setup(start_s: float = 10.0):
    backend = RecordingBackend()
    inbox = Inbox(stops=FakeQueue(), goals=FakeQueue(), supervisor=FakeQueue(), commands=FakeQueue(),
                  grips=FakeQueue())
    return backend, inbox, ArmLoop(backend, CONFIG, start_s=start_s)


def _command(inbox: Inbox, rx_s: float, target: np.ndarray, goal_id: str = "g1", seq: int = 0) -> None:
    inbox.commands.put(rx_s, names=list(SimBackend().joint_names), position_rad=target.tolist(),
                       velocity_rad_s=[], goal_id=goal_id, source="motion", seq=seq)


def _stop(inbox: Inbox, rx_s: float, protective: bool = False) -> Received:
    return inbox.stops.put(rx_s, reason="release", protective=protective, source="supervisor", stamp_ns=0)


def test_a_valid_command_moves_the_arm_and_the_state_says_not_holding():
    backend, inbox, arm = _setup()
    first = arm.tick(10.0, inbox)
    assert first["holding"] and first["backend"] == "sim" and first["enabled"]
    assert first["names"] == list(backend.joint_names)
    target = HOME + np.array([0.2, 0, 0, 0, 0, 0, 0])
    t = 10.0
    for k in range(10):
        t += PERIOD_S
        _command(inbox, t, target, seq=k)
        state = arm.tick(t, inbox)
    assert not state["holding"]
    assert state["position_rad"][0] > HOME[0] + 0.01
    assert arm.gate.accepted == 10


def moving_arm(phase: str | None = None):
    """An arm on its way to a goal 1 rad off home after 20 ticks (with supervisor states of
    `phase`, episode 1, when given): (backend, inbox, arm loop, target, time of the last tick)."""
    backend, inbox, arm = _setup()
    target = HOME + np.array([1.0, 0, 0, 0, 0, 0, 0])
    t = 10.0
    for k in range(20):
        t += PERIOD_S
        _command(inbox, t, target, seq=k)
        if phase is not None:
            inbox.supervisor.put(t, episode_id=1, phase=phase)
        arm.tick(t, inbox)
    assert backend.read().velocity_rad_s[0] > 0.1
    return backend, inbox, arm, target, t


def test_a_stop_brakes_and_ignores_the_stopped_goals_commands_until_a_newer_goal():
    backend, inbox, arm, target, t = moving_arm()
    moving = backend.read().velocity_rad_s[0]
    assert moving > 0.1
    t += PERIOD_S
    stop = _stop(inbox, t - 0.001)
    _command(inbox, t, target, seq=99)  # the stopped goal's command, after the stop
    state = arm.tick(t, inbox)
    assert arm.brake.active and state["holding"] and arm.newest_stop is stop
    assert arm.brake.ignored_commands == 1
    assert 0.0 <= state["velocity_rad_s"][0] < moving
    # A goal sent after the stop: its commands reach the arm again.
    t += PERIOD_S
    inbox.goals.put(t - 0.002, goal_id="g2", source="supervisor", stamp_ns=0)
    _command(inbox, t, target, goal_id="g2")
    assert not arm.tick(t, inbox)["holding"] and not arm.brake.active


def test_a_new_episode_resets_the_scene_and_ends_a_protective_stop_latch():
    backend, inbox, arm = _setup()
    inbox.supervisor.put(10.0, episode_id=1, phase="locate")
    arm.tick(10.0, inbox)
    assert backend.episodes == 0  # the first episode seen is no change
    _stop(inbox, 10.005, protective=True)
    arm.tick(10.01, inbox)
    assert arm.brake.protective
    inbox.supervisor.put(10.015, episode_id=2, phase="locate")
    arm.tick(10.02, inbox)
    assert backend.episodes == 1 and not arm.brake.protective and arm.episode_id == 2


def test_the_newest_grip_command_is_passed_on():
    backend, inbox, arm = _setup()
    inbox.grips.put(10.0, grip_force_n=3.0)
    inbox.grips.put(10.001, grip_force_n=5.0)
    arm.tick(10.005, inbox)
    arm.tick(10.015, inbox)
    assert [c for c in backend.calls if c[0] == "grip"] == [("grip", 5.0)]


def test_a_stall_is_caught_up_and_the_tick_steps_one_period():
    backend, inbox, arm = _setup()
    arm.tick(10.0, inbox)
    arm.tick(10.0 + STALL_PERIODS * PERIOD_S, inbox)  # not a stall: exactly the limit
    late_s = 10.0 + STALL_PERIODS * PERIOD_S + 0.5
    arm.tick(late_s, inbox)
    assert backend.calls[1] == ("step", pytest.approx(STALL_PERIODS * PERIOD_S))
    assert backend.calls[2:] == [("catch_up", pytest.approx(0.5 - PERIOD_S)), ("step", pytest.approx(PERIOD_S))]


def test_unchanged_truth_goes_out_every_repeat_period_other_extras_every_tick():
    backend, inbox, arm = _setup()
    sent: list[str] = []
    backend.truth.append({"object_position_m": (0.1, 0.2, 0.3)})
    for k in range(25):
        arm.publish_extras(lambda suffix, fields: sent.append(suffix), 10.0 + k * PERIOD_S)
    truth = [s for s in sent if s == topics.SIM_TRUTH.suffix]
    assert len(truth) == 1 + int(24 * PERIOD_S / TRUTH_REPEAT_S + 1e-9)
    assert sent.count("sensors/other") == 25 and arm.truth_gate.skipped == 25 - len(truth)
    backend.truth.append({"object_position_m": (0.1, 0.2, 0.31)})  # moved: at once
    arm.publish_extras(lambda suffix, fields: sent.append(suffix), 10.0 + 25 * PERIOD_S)
    assert sent[-2] == topics.SIM_TRUTH.suffix


def test_the_brakes_ramp_goes_on_through_a_stall():
    backend, inbox, arm = _setup()
    target = HOME + np.array([1.0, 0, 0, 0, 0, 0, 0])
    t = 10.0
    for k in range(20):
        t += PERIOD_S
        _command(inbox, t, target, seq=k)
        arm.tick(t, inbox)
    _stop(inbox, t + 0.001)
    t += PERIOD_S
    arm.tick(t, inbox)
    assert arm.brake.active and not arm.brake.at_rest  # about 1 rad/s at 40 rad/s²: 25 ms to rest
    arm.tick(t + 0.1, inbox)  # a 0.1 s stall: the ramp ran through it
    assert arm.brake.at_rest


def test_the_backend_hears_whether_an_episode_runs_once_per_change():
    """`Backend.episode_running`: true until a supervisor state says otherwise (no supervisor:
    as in an episode), then once per change of the newest phase in or out of an episode."""
    backend, inbox, arm = _setup()
    t = 10.0
    told = []
    for phase in (None, "locate", "transfer", "retract", "done", "done", "idle", "locate", "protective_stop"):
        t += PERIOD_S
        if phase is not None:
            inbox.supervisor.put(t, episode_id=1, phase=phase)
        arm.tick(t, inbox)
        told.append(backend.told_running)
        backend.told_running = []
    assert told == [[True], [], [], [], [False], [], [], [True], [False]]
