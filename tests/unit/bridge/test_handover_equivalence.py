"""The sim backend's cheaper tick publishes what the old full stepping published, bit for bit.

Two backends of the default profile run the same scripted handover side by side
(`handover_script`: empty move, pick, held still, carry, transfer with a taking or a dropping
receiver, rest; short extra ticks and a catch-up gap; a commanded hold; a new episode):

- `FullStepping`, the tick as it was: the arm servo stepped, the tool's FK evaluated, every
  1 kHz plant step run through the plant's generic equations (`step_generic`), each tick;
- the backend as it is: resting servo steps and unchanged FK skipped, the plant stepped on
  floats and its resting steps replayed (`robot_sim.contact.rest`).

Every tick, the published fields, the joint reading and the whole scene state (object,
hand, phases, plant, arm, tool) must be equal by `repr` (−0.0 is not 0.0), and the scene's
output must be what the scene built from the plant's `Observation` before.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from handover_model.robots.baxter import arm_model
from robot_sim.contact.config import ContactSimError
from robot_sim.contact.generic_step import step_generic
from robot_sim.arm import SimulatedArm
from robot_sim.contact.plant import ContactPlant
from robot_sim.handover_scene import HandoverScene, SceneOutput, SceneParams
from services.bridge.handover_backend import HandoverSimBackend
from tests.unit.bridge import handover_script as hs
from tests.unit.contact.helpers import plant_state


class FullPlant(ContactPlant):
    """The plant stepped as before: every step through the generic equations."""

    def run(self, duration_s: float, grip_command_n) -> None:
        cmd = np.asarray(grip_command_n, dtype=float)
        if not math.isfinite(duration_s) or duration_s < 0 or not np.all(np.isfinite(cmd)) or np.any(cmd < 0):
            raise ContactSimError("bad duration or command")
        self.ft_fresh = self.optical_fresh = False
        for _ in range(max(1, int(round(duration_s / self.dt_s)))):
            step_generic(self, float(cmd))


class FullStepping(HandoverSimBackend):
    """The backend's tick as it was: servo, FK and every plant step each tick."""

    def __init__(self, params: SceneParams, **kwargs) -> None:
        super().__init__(params, **kwargs)
        self.scene.plant_type = FullPlant

    def command(self, target_rad, feedforward_rad_s=None) -> None:
        self._holding_target = None
        self.arm.set_target(target_rad, feedforward_rad_s)

    def step(self, dt_s: float) -> None:
        self.arm.step(dt_s)
        tool = arm_model().tool_pose(self.arm.state.position_rad)[0]
        if dt_s > 0:
            self._tool_speed = float(np.linalg.norm(tool - self._tool) / dt_s)
        self._tool = tool
        with self._lock:
            if self._reset_pending:
                self.scene.reset()
                self._reset_pending = False
            self._out = self.scene.step(dt_s, tool, self._tool_speed, self.grip_command_n)


def full_stepping(behaviour: str) -> FullStepping:
    """`FullStepping` for the default profile, as `make_backend` builds the real one."""
    config = hs.profile_config(behaviour)
    c = config.contact
    params = SceneParams(behaviour=c.behaviour, receiver=dict(c.receiver), pull_angle_deg=c.pull_angle_deg,
                         object_mass_kg=c.object_mass_kg, mu_static=c.mu_static, mu_kinetic=c.mu_kinetic,
                         seed=c.seed, height_m=c.height_m, posture=c.posture)
    return FullStepping(params, time_constant_s=config.servo_time_constant_s,
                        robot_command_timeout_s=config.sim_robot_command_timeout_s)


def output_from_observation(scene: HandoverScene) -> SceneOutput | None:
    """The scene's output as it was built before: from the plant's `Observation`."""
    if scene.plant is None:
        return None
    obs = scene.plant.observation()
    holder = {"on_table": "table", "dropped": "none"}.get(scene.object_phase)
    in_pads = not bool(obs.left_pads) and float(obs.grip_force_n) > 0.0
    receiver = bool(obs.receiver_holds)
    if holder is None:
        holder = "both" if in_pads and receiver else "gripper" if in_pads else "receiver" if receiver else "none"
    return SceneOutput(
        wrist_force_n=(float(obs.wrist_force_x_n), float(obs.wrist_force_y_n)),
        optical_counts=(float(obs.optical_counts_x), float(obs.optical_counts_y)),
        optical_counts_per_m=float(obs.optical_counts_per_m), optical_dt_s=float(obs.optical_dt_s),
        optical_valid=bool(obs.optical_valid),
        slip_velocity_m_s=(float(obs.slip_velocity_x_m_s), float(obs.slip_velocity_y_m_s)),
        accel_y_m_s2=float(obs.accel_y_m_s2), object_phase=scene.object_phase, receiver_phase=scene.receiver_phase,
        object_position_m=scene.object_m.copy(), object_velocity_m_s=scene.object_velocity_m_s.copy(),
        held_by=holder, dropped=bool(obs.dropped), slip_m=float(obs.object_position_y_m),
        grip_force_n=max(0.0, float(obs.grip_force_n)), receiver_hand_m=scene.hand_m.copy(),
        receiver_pull_n=float(obs.pull_force_x_n),
    )


def published(backend: HandoverSimBackend) -> str:
    """What one tick publishes: the joint reading and the backend's extras, as exact text."""
    extras: list = []
    backend.publish_extras(lambda suffix, fields: extras.append((suffix, fields)))
    r = backend.read()
    return repr((r.position_rad.tolist(), r.velocity_rad_s.tolist(), r.effort_nm.tolist(), extras))


def scene_state(backend: HandoverSimBackend) -> str:
    sc, arm = backend.scene, backend.arm
    return repr((sc.object_phase, sc.receiver_phase, sc.object_m.tolist(), sc.object_velocity_m_s.tolist(),
                 sc.hand_m.tolist(), None if sc._origin_m is None else sc._origin_m.tolist(), sc._reach_elapsed_s,
                 sc._reach_start_hand_m.tolist(), sc.episode, None if sc.plant is None else plant_state(sc.plant),
                 arm.state.position_rad.tolist(), arm.state.velocity_rad_s.tolist(), arm.target_rad.tolist(),
                 arm.feedforward_rad_s.tolist(), backend._tool.tolist(), backend._tool_speed))


def episode(backend: HandoverSimBackend, poses: hs.Poses) -> list[hs.Tick]:
    """The scripted episode's ticks for `backend` (run on it), then a commanded hold: the
    same command array again and again (a gate between commands), then equal new arrays."""
    ticks = []
    for tick in hs.script(backend, poses, rest_s=1.5):
        hs.apply(backend, tick)
        ticks.append(tick)
    target, zero = poses.transfer.copy(), np.zeros(7)
    held = [hs.Tick(target, zero, 0.0) for _ in range(40)] + [hs.Tick(target.copy(), zero.copy(), 0.0)
                                                               for _ in range(40)]
    for tick in held:
        hs.apply(backend, tick)
    return ticks + held


@pytest.mark.parametrize("behaviour", ["taking", "dropping"])
def test_the_cheaper_tick_publishes_what_full_stepping_published(behaviour):
    poses = hs.poses()
    script = episode(hs.default_backend(behaviour), poses)
    script = script + [hs.Tick(None, None, 0.0, dt_s=0.01, state="reset")] + script  # a new episode
    new, old = hs.default_backend(behaviour), full_stepping(behaviour)
    rests = {"plant": 0, "arm": 0}
    for i, tick in enumerate(script):
        for backend in (new, old):
            if tick.state == "reset":
                backend.new_episode()
            hs.apply(backend, tick)
        assert published(new) == published(old), f"tick {i} ({tick.state})"
        assert scene_state(new) == scene_state(old), f"tick {i} ({tick.state})"
        expected = output_from_observation(new.scene)
        if expected is not None:
            assert repr(new._out) == repr(expected), f"tick {i} ({tick.state})"
        rests["plant"] += new.scene.plant is not None and new.scene.plant._rest is not None
        rests["arm"] += new._at_rest is not None
    # The skipped paths were taken (the comparison is not empty): the plant rests while the
    # object waits in the gripper and is carried, the arm while it holds.
    assert rests["plant"] > 300 and rests["arm"] > 300, rests
    assert new.scene.episode == old.scene.episode == 2


def test_the_arm_rests_through_a_jittered_loop_bit_for_bit():
    """A real loop's dt moves every tick (9.6–19 ms here): the servo settled a few units in
    the last place short of its target still skips its steps, and what is published stays
    that of full stepping."""
    rng = np.random.default_rng(7)
    poses = hs.poses()
    held = [hs.Tick(poses.transfer, np.zeros(7), 0.0) for _ in range(400)]  # settles ulps short of it
    # Late ticks up to 19 ms too: a bound proven too long would skip a step that moves the arm.
    script = [dataclasses.replace(tick, dt_s=tick.dt_s * float(rng.uniform(0.96, 1.9 if i % 7 == 0 else 1.26)))
              for i, tick in enumerate(episode(hs.default_backend("taking"), poses) + held)]
    new, old = hs.default_backend("taking"), full_stepping("taking")
    skipped = 0
    for i, tick in enumerate(script):
        before = new._at_rest
        for backend in (new, old):
            hs.apply(backend, tick)
        assert published(new) == published(old), f"tick {i}"
        assert scene_state(new) == scene_state(old), f"tick {i}"
        skipped += before is not None and new._at_rest is before
    assert skipped > 700, skipped  # 447 when only a step's own dt counted


def test_the_settled_servo_bound_is_exact_for_every_dt_under_it():
    """`SimulatedArm.still_for_dt_up_to_s`: a full servo step of any dt up to the bound leaves
    a settled arm bit for bit as it is; a moving arm or a feed-forward proves nothing."""
    rng = np.random.default_rng(3)
    for trial in range(20):
        arm = SimulatedArm(0.05)
        arm.set_target(arm.state.position_rad + rng.uniform(-0.5, 0.5, 7))
        for _ in range(3000):
            arm.step(0.01)
        bound = arm.still_for_dt_up_to_s()
        assert bound > 0.0105, (trial, bound)  # the 100 Hz loop's ticks rest
        settled = repr((arm.state.position_rad.tolist(), arm.state.velocity_rad_s.tolist()))
        for dt in [bound, *rng.uniform(1e-6, bound, 200).tolist()]:
            probe = SimulatedArm(0.05, initial_position_rad=arm.state.position_rad)
            probe.state, probe.target_rad = arm.state, arm.target_rad
            after = probe.step(dt)
            assert repr((after.position_rad.tolist(), after.velocity_rad_s.tolist())) == settled, (trial, dt)
    for error in (1e-15, 1e-12, 1e-9, 1e-6, 1e-3, 0.1):  # any error, tiny dts included
        arm = SimulatedArm(0.05)
        arm.set_target(arm.state.position_rad + error)
        bound = arm.still_for_dt_up_to_s()
        for dt in [bound, bound / 2, bound * 1e-3]:
            if dt > 0.0:
                probe = SimulatedArm(0.05, initial_position_rad=arm.state.position_rad)
                probe.target_rad = arm.target_rad
                assert probe.step(dt).position_rad.tolist() == arm.state.position_rad.tolist(), (error, dt)
    moving = SimulatedArm(0.05)
    moving.set_target(moving.state.position_rad + 0.3)
    moving.step(0.01)
    assert moving.still_for_dt_up_to_s() == 0.0
    fed = SimulatedArm(0.05)
    fed.set_target(fed.state.position_rad, feedforward_rad_s=np.full(7, 1e-3))
    assert fed.still_for_dt_up_to_s() == 0.0


def test_an_infinite_dt_is_never_skipped():
    """A rest proven for any dt (every error ±0.0, a −0.0 target against +0.0 positions) does
    not cover dt = inf: that step is taken, as full stepping takes it."""
    new, old = hs.default_backend("taking"), full_stepping("taking")
    for backend in (new, old):
        q = backend.arm.state.position_rad
        backend.command(np.where(q == 0.0, -0.0, q))
        backend.step(0.01)
    assert new._at_rest is not None
    with np.errstate(invalid="ignore"):
        new.step(math.inf)
        old.step(math.inf)
    assert repr(new.arm.state) == repr(old.arm.state)


def test_a_wrongly_skipped_servo_step_is_caught():
    """The comparison catches a servo step skipped while the arm moves."""
    poses = hs.poses()
    new, old = hs.default_backend("taking"), full_stepping("taking")
    move = list(hs.empty_moves(poses))[:50]
    for tick in move[:20]:
        hs.apply(new, tick)
        hs.apply(old, tick)
    assert scene_state(new) == scene_state(old)
    tick = move[20]
    for backend in (new, old):
        backend.command(tick.target_rad, tick.feedforward_rad_s)
    arm = new.arm
    new._at_rest = (arm.state, 0.01, (arm.target_rad.tobytes(), arm.feedforward_rad_s.tobytes(),
                                      arm.time_constant_s), 0.0)  # wrong: the arm moves
    new.step(0.01)
    old.step(0.01)
    assert published(new) != published(old)


def test_between_episodes_the_held_object_sleeps_and_publishes_what_it_would_have():
    """`HandoverSimBackend.episode_running(False)`: after the handover the receiver's still
    grip sleeps (`robot_sim.contact.rest`); what the backend publishes differs from full
    stepping by less than 1e-9 (m, N); a new episode's start wakes it."""
    poses = hs.poses()
    new, old = hs.default_backend("taking"), full_stepping("taking")
    for tick in episode(hs.default_backend("taking"), poses):
        for backend in (new, old):
            hs.apply(backend, tick)
    assert new.scene.object_phase == "with_receiver"
    new.episode_running(False)
    hold = hs.Tick(None, None, 0.0)
    slept = 0
    for _ in range(300):
        for backend in (new, old):
            hs.apply(backend, hold)
        slept += not new.scene.plant._rest.proven if new.scene.plant._rest is not None else 0
        assert _close(_extras(new), _extras(old)), _extras(new)
    assert slept > 200, slept
    new.episode_running(True)
    hs.apply(new, hold)
    assert new.scene.plant._rest is None or new.scene.plant._rest.proven
    # The next episode after a sleep: bit for bit what full stepping does.
    hs.apply(old, hold)
    second = episode(hs.default_backend("taking"), poses)
    for backend in (new, old):
        backend.new_episode()
    for i, tick in enumerate(second):
        for backend in (new, old):
            hs.apply(backend, tick)
        assert published(new) == published(old), f"second episode, tick {i}"
        assert scene_state(new) == scene_state(old), f"second episode, tick {i}"


def _extras(backend: HandoverSimBackend) -> list[float]:
    """Every number the backend's extra messages carry, in order."""
    out: list[float] = []
    backend.publish_extras(lambda _suffix, fields: out.extend(_numbers(fields.values())))
    return out


def _numbers(values) -> list[float]:
    out: list[float] = []
    for v in values:
        if isinstance(v, (tuple, list)):
            out.extend(_numbers(v))
        elif isinstance(v, (bool, int, float)):
            out.append(float(v))
    return out


def _close(a: list[float], b: list[float]) -> bool:
    return len(a) == len(b) and all(abs(x - y) < 1e-9 for x, y in zip(a, b))
