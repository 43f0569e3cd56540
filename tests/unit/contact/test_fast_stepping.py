"""The one-episode plant's fast paths give the generic step's results bit for bit.

`robot_sim.contact.scalar_step.run_steps` (the step inline on floats) and the resting replay
of `robot_sim.contact.rest` (steps that change nothing: only the sensors' own work) are
checked against `robot_sim.contact.generic_step.step_generic`, the plant's equations written
once for both backends, state by state (every variable, sensor and noise draw, compared by
`repr`: −0.0 is not 0.0)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robot_sim.contact.config import SensorParams, SimConfig
from robot_sim.contact.generic_step import step_generic
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import absent, behaviour_by_name, reference, sample_behaviours, taking
from robot_sim.contact.rest import Rest
from tests.unit.contact.helpers import plant_state as state

NOISY = SimConfig(sensors=SensorParams(accel_noise_snr_db=3.0, grip_noise_snr_db=6.0, accel_filter_hz=20.0,
                                       accel_noise_std_m_s2=0.05))
BEHAVIOURS = ("taking", "dropping", "bumping", "hesitating", "absent")


def reference_run(p: ContactPlant, elapsed_s: float, grip_command_n: float) -> None:
    """`ContactPlant.run_real_time` as it was: the carry, then whole generic steps."""
    p._carry_s += elapsed_s
    steps = int(math.floor(p._carry_s / p.dt_s + 1e-9))
    if steps >= 1:
        p._carry_s = max(0.0, p._carry_s - steps * p.dt_s)
        p.ft_fresh = p.optical_fresh = False
        for _ in range(steps):
            step_generic(p, grip_command_n)


def side_by_side(config, receiver, commands, seed=0, dts=None):
    """Run `commands` (N, one per tick) on a fast plant and a generic one; return the fast
    plant and how many ticks ended at rest. Fails at the first tick whose states differ."""
    fast = ContactPlant(config, receiver, seed=seed, initial_grip_force_n=10.0)
    slow = ContactPlant(config, receiver, seed=seed, initial_grip_force_n=10.0)
    resting = 0
    for i, cmd in enumerate(commands):
        dt = 0.01 if dts is None else dts[i]
        fast.run_real_time(dt, cmd)
        reference_run(slow, dt, cmd)
        resting += fast._rest is not None
        assert state(fast) == state(slow), f"tick {i}"
    return fast, resting


def command_schedule(seed: int, ticks: int = 500) -> list[float]:
    """Grip commands (N) that change now and then, including changes that keep the target."""
    rng = np.random.default_rng(seed)
    out, cmd = [], 10.0
    for _ in range(ticks):
        if rng.random() < 0.04:
            cmd = float(rng.choice([0.0, -0.0, 2.0, 10.0, 10.000000000000002, 15.0]))
        out.append(cmd)
    return out


@pytest.mark.parametrize("config", [SimConfig(), NOISY], ids=["default", "noisy"])
@pytest.mark.parametrize("name", BEHAVIOURS)
def test_fast_real_time_stepping_equals_the_generic_step(config, name):
    dts = [0.01 if i % 11 else 0.0037 for i in range(500)]  # short and late ticks carry fractions
    _, resting = side_by_side(config, behaviour_by_name(name), command_schedule(len(name)), seed=3, dts=dts)
    if name == "absent" and config is not NOISY:
        assert resting > 100  # the rest is entered (the object still in the gripper)


def test_sampled_receivers_equal_the_generic_step():
    for i, receiver in enumerate(sample_behaviours("mixed", 8, np.random.default_rng(4))):
        side_by_side(SimConfig(), receiver, command_schedule(i, 300), seed=i)


def test_single_steps_equal_the_generic_step():
    for name in BEHAVIOURS:
        fast = ContactPlant(NOISY, behaviour_by_name(name), seed=1)
        slow = ContactPlant(NOISY, behaviour_by_name(name), seed=1)
        for k, cmd in enumerate(command_schedule(2, 3000)):
            fast.step(cmd)
            step_generic(slow, cmd)
            if k % 50 == 0:
                assert state(fast) == state(slow), (name, k)
        assert state(fast) == state(slow)


def test_the_rest_ends_when_the_reference_starts_moving():
    # The object rests in the pads while the receiver waits; its reach starts at 1.5 s and
    # the rest must end on the very step the reference changes.
    fast, resting = side_by_side(SimConfig(), taking(reach_start_s=1.5), [10.0] * 400)
    assert resting > 50 and fast._rest is None


def test_the_rest_ends_on_a_new_target_and_on_a_new_receiver():
    commands = [10.0] * 100 + [10.000000000000002] * 30 + [6.0] * 200
    fast, resting = side_by_side(SimConfig(), absent(), commands)
    assert resting > 100
    # A replaced receiver ends the rest (the plant's constants changed).
    fast.run_real_time(0.5, 6.0)
    assert fast._rest is not None
    fast.replace_receiver(taking(reach_start_s=fast.time_s - 0.8))
    assert fast._rest is None


def test_a_step_taken_elsewhere_ends_the_rest():
    plant = ContactPlant(SimConfig(), absent(), seed=0)
    plant.run_real_time(0.1, 10.0)
    assert plant._rest is not None
    plant.step(10.0)
    assert plant._rest is None


def test_a_moving_state_is_never_taken_for_a_rest():
    plant = ContactPlant(SimConfig(), absent(), seed=0, initial_grip_force_n=10.0)
    plant.run_real_time(0.05, 1.0)  # the grip drops below the weight: the object slides
    for _ in range(30):
        plant.run_real_time(0.01, 1.0)
        assert plant._rest is None or plant.vy == 0.0


def test_a_wrongly_entered_rest_is_caught_by_the_comparison():
    """The side-by-side check would catch a rest entered in a state that changes: forced into
    one while the object slides out of a weak grip (the reference is constant there, so only
    the entry test stands in the way), the plant's state leaves the generic step's."""
    fast = ContactPlant(SimConfig(), absent(), seed=0, initial_grip_force_n=1.0)
    slow = ContactPlant(SimConfig(), absent(), seed=0, initial_grip_force_n=1.0)
    fast.run_real_time(0.02, 1.0)
    reference_run(slow, 0.02, 1.0)
    assert state(fast) == state(slow) and fast.vy > 0.0 and fast._rest is None  # sliding: no rest
    fast._rest = Rest(fast._reference_at(fast.step_index - 1), False, fast.step_index)  # entered wrongly
    fast.run_real_time(0.01, 1.0)
    reference_run(slow, 0.01, 1.0)
    assert state(fast) != state(slow)


def test_cached_reference_samples_are_the_reference_bit_for_bit():
    dt = SimConfig().dt_s
    for receiver in (taking(), behaviour_by_name("dropping"), absent()):
        plant = ContactPlant(SimConfig(), receiver)
        n = 6000
        direct = np.stack(np.broadcast_arrays(*reference(np.arange(n) * dt, receiver)), axis=1)
        cached = np.array([plant._reference_at(k) for k in range(n)])
        assert cached.tobytes() == direct.tobytes()
        # Equal consecutive samples are one object (the rest checks identity), and the
        # reference is known constant once every window has ended.
        assert plant._reference_at(n - 1) is plant._reference_at(n - 2)
        assert plant._ref_settled is not None
