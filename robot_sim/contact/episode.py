"""Closed-loop runs: plant + grip controller, for one episode (trace) or a batch (outcomes)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from robot_sim.contact.config import ContactSimError, SimConfig
from handover_model.grip import GripController, SensorSample
from robot_sim.contact.outcome import (
    BatchOutcome,
    EpisodeOutcome,
    EpisodeTrace,
    OutcomeAccumulator,
    outcome_from_trace,
)
from robot_sim.contact.plant import ContactPlant, TraceRecorder
from robot_sim.contact.receiver import ReceiverParams

__all__ = ["EpisodeResult", "rest_sample", "run_episode", "run_vectorised"]


@dataclass(frozen=True)
class EpisodeResult:
    """One simulated episode: its trace and its outcome."""

    trace: EpisodeTrace
    outcome: EpisodeOutcome


def rest_sample(config: SimConfig, n: int) -> SensorSample:
    """Sensor sample of an object at rest in the gripper at t = 0 (F_sy = W, all else 0)."""
    z = np.zeros(n)
    return SensorSample(time_s=0.0, force_x_n=z, force_y_n=np.full(n, config.obj.weight_n),
                        accel_y_m_s2=z, slip_velocity_x_m_s=z, slip_velocity_y_m_s=z,
                        optical_valid=np.ones(n, dtype=bool), grip_force_n=z)


def _control_every(config: SimConfig, controller: GripController) -> int:
    period = float(getattr(controller, "period_s", 0.01))
    if not (np.isfinite(period) and period > 0):
        raise ContactSimError(f"controller period_s must be > 0, got {period}")
    return max(1, int(round(period / config.dt_s)))


def _command_one(controller: GripController, sample: SensorSample) -> float:
    """Grip command of a one-episode controller as a float (N, >= 0), checked."""
    cmd = controller.step(sample)
    try:
        (value,) = np.ravel(cmd)
    except ValueError:
        raise ContactSimError(f"controller returned shape {np.shape(cmd)}, expected (1,)") from None
    value = float(value)
    if not math.isfinite(value):
        raise ContactSimError("controller returned a non-finite grip force")
    return value if value > 0.0 else 0.0


def _command(controller: GripController, sample: SensorSample, n: int) -> np.ndarray:
    cmd = np.asarray(controller.step(sample), dtype=float)
    if cmd.shape not in ((n,), ()):
        raise ContactSimError(f"controller returned shape {cmd.shape}, expected ({n},)")
    if not np.all(np.isfinite(cmd)):
        raise ContactSimError("controller returned a non-finite grip force")
    return np.broadcast_to(np.maximum(cmd, 0.0), (n,))


def run_episode(config: SimConfig, receiver: ReceiverParams, controller: GripController, seed: int = 0,
                label: str = "") -> EpisodeResult:
    """Simulate one episode (Python-float plant) and judge it from ground truth."""
    if np.ndim(receiver.pull_angle_rad) != 0:
        raise ContactSimError("run_episode takes one receiver behaviour; use run_vectorised for a batch")
    every = _control_every(config, controller)
    controller.reset(1)
    cmd = _command_one(controller, rest_sample(config, 1))
    plant = ContactPlant(config, receiver, seed=seed, initial_grip_force_n=cmd)
    rec = TraceRecorder()
    rec.record(plant, cmd)
    keep = config.record_every
    for k in range(1, config.n_steps + 1):
        plant.step(cmd)
        if k % every == 0:
            cmd = _command_one(controller, plant.sensor_sample())
        if k % keep == 0:
            rec.record(plant, cmd)
    trace = rec.trace(label)
    return EpisodeResult(trace=trace, outcome=outcome_from_trace(trace, config.drop_distance_m))


def run_vectorised(config: SimConfig, receivers: ReceiverParams, controller: GripController,
                   seed: int | np.random.SeedSequence = 0) -> BatchOutcome:
    """Simulate n episodes at once on numpy arrays (receivers stacked, shape (n,))."""
    if np.ndim(receivers.pull_angle_rad) != 1:
        raise ContactSimError("run_vectorised needs stacked receivers (see receiver.stack_receivers)")
    n = receivers.n_episodes
    every = _control_every(config, controller)
    controller.reset(n)
    cmd = _command(controller, rest_sample(config, n), n).copy()
    plant = ContactPlant(config, receivers, seed=seed, initial_grip_force_n=cmd)
    acc = OutcomeAccumulator(n, config.drop_distance_m)

    def record() -> None:
        acc.update(plant.time_s, plant.mode, plant.pull_x, plant.pull_y, plant.px, plant.py, plant.ay, plant.holds)

    record()
    keep = config.record_every
    for k in range(1, config.n_steps + 1):
        plant.step(cmd)
        if k % every == 0:
            cmd = _command(controller, plant.sensor_sample(), n)
        if k % keep == 0:
            record()
    return acc.result()
