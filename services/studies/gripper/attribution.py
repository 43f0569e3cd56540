"""Who dropped the object? Drop attribution and overshoot pairing for the benchmark.

A drop in the Monte-Carlo benchmark is not always the controller's fault. For every
episode we run, on the *same* episode and noise, a reference that no grip law can beat on
this plant:

- **max-hold reference**: the command is the actuator's largest force from t = 0 and never
  drops (`MaxHoldReference`). More normal force only widens the friction cone, so if the
  object leaves the pads even then, the receiver's pull or the friction (μ, weight) is
  beyond what the gripper can hold: **unavoidable** with this actuator.

Each drop of a controller falls in exactly one class (`DropClass`):

- ``unavoidable``: the max-hold reference drops it too;
- ``receiver_let_go``: the gripper had released for good while the receiver held the
  object (ground truth `receiver_holds` at the start of the final release), and the object
  fell afterwards: the receiver let go of an object that was already theirs;
- ``controller``: every other drop (the gripper let it slide out, or released while the
  receiver did not hold it).

"Drops because of the controller" = ``controller`` drops. Both the total drop rate and
this one are reported.

Overshoot pairing: the benchmark's force overshoot is taken over all *taking* episodes,
including the ones a controller dropped, where the receiver often never pulled hard. A
controller that drops light objects early therefore gets a *lower* overshoot. `paired
overshoot` compares two controllers only on the taking episodes both handed over.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from handover_model.grip import GripController, Mode, SensorSample
from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.episode import rest_sample
from robot_sim.contact.outcome import BatchOutcome, OutcomeAccumulator
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import ReceiverParams

__all__ = ["DropClass", "MaxHoldReference", "ReactiveMaxHold", "AttributedOutcome", "run_attributed", "classify_drops"]


class DropClass(IntEnum):
    """Why an episode was dropped (NONE: not dropped)."""

    NONE = 0
    UNAVOIDABLE = 1
    RECEIVER_LET_GO = 2
    CONTROLLER = 3


class MaxHoldReference:
    """Commands the largest grip force from the start and never lets go (a bound, not a
    controller anyone should use: it never hands anything over).

    Attributes:
        grip_force_n: the constant command, N (the actuator clamps it to its maximum).
    """

    def __init__(self, grip_force_n: float = 140.0, period_s: float = 0.01) -> None:
        self.grip_force_n = float(grip_force_n)
        self.period_s = float(period_s)

    def reset(self, n_episodes: int = 1) -> None:
        self.n_episodes = int(n_episodes)
        self.mode = np.zeros(self.n_episodes, dtype=np.int8)

    def step(self, sample: SensorSample) -> np.ndarray:
        return np.full(self.n_episodes, self.grip_force_n)


class ReactiveMaxHold:
    """Starts at a modest rest grip and commands the largest force at the first sign of a
    pull or a slide; never lets go. The fastest reaction any sensor-driven law can have: if
    it drops an object, only a harder grip *before* anything happened would have held it.

    Rest grip: `hold_per_weight` × F_sy of the first sample + `min_hold_force_n` (SG's
    default hold). Trigger: the wrist force changed by more than `trigger_n` from rest, or
    the optical sensor sees a slip faster than `slip_speed_threshold_m_s`.
    """

    def __init__(self, hold_per_weight: float = 4.0, min_hold_force_n: float = 1.0, trigger_n: float = 0.5,
                 slip_speed_threshold_m_s: float = 0.005, grip_force_n: float = 140.0, period_s: float = 0.01) -> None:
        self.hold_per_weight, self.min_hold_force_n = float(hold_per_weight), float(min_hold_force_n)
        self.trigger_n, self.slip_speed_threshold_m_s = float(trigger_n), float(slip_speed_threshold_m_s)
        self.grip_force_n, self.period_s = float(grip_force_n), float(period_s)

    def reset(self, n_episodes: int = 1) -> None:
        self.n_episodes = int(n_episodes)
        self.rest: np.ndarray | None = None
        self.triggered = np.zeros(self.n_episodes, dtype=bool)
        self.mode = np.zeros(self.n_episodes, dtype=np.int8)

    def step(self, sample: SensorSample) -> np.ndarray:
        f = np.stack([np.broadcast_to(sample.force_x_n, (self.n_episodes,)),
                      np.broadcast_to(sample.force_y_n, (self.n_episodes,))])
        if self.rest is None:
            self.rest = f.copy()
        speed = np.hypot(sample.slip_velocity_x_m_s, sample.slip_velocity_y_m_s)
        slip = np.asarray(sample.optical_valid, dtype=bool) & (speed > self.slip_speed_threshold_m_s)
        self.triggered |= (np.hypot(*(f - self.rest)) > self.trigger_n) | slip
        rest_grip = self.hold_per_weight * self.rest[1] + self.min_hold_force_n
        return np.where(self.triggered, self.grip_force_n, rest_grip)


@dataclass(frozen=True)
class AttributedOutcome:
    """A batch outcome plus what the attribution needs (arrays of shape (n,)).

    Attributes:
        outcome: the usual ground-truth outcome.
        holds_at_release: the receiver held the object when the final release started
            (False where never released).
    """

    outcome: BatchOutcome
    holds_at_release: np.ndarray

    def __len__(self) -> int:
        return len(self.outcome)

    @staticmethod
    def concatenate(parts: list["AttributedOutcome"]) -> "AttributedOutcome":
        return AttributedOutcome(outcome=BatchOutcome.concatenate([p.outcome for p in parts]),
                                 holds_at_release=np.concatenate([p.holds_at_release for p in parts]))


def run_attributed(config: SimConfig, receivers: ReceiverParams, controller: GripController,
                   seed: int | np.random.SeedSequence = 0) -> AttributedOutcome:
    """`robot_sim.contact.episode.run_vectorised` that also records whether the receiver
    held the object at the start of the final release (same plant, same noise, same
    outcome numbers)."""
    if np.ndim(receivers.pull_angle_rad) != 1:
        raise ContactSimError("run_attributed needs stacked receivers (see receiver.stack_receivers)")
    n = receivers.n_episodes
    every = max(1, int(round(float(controller.period_s) / config.dt_s)))
    controller.reset(n)
    cmd = np.maximum(np.asarray(controller.step(rest_sample(config, n)), dtype=float), 0.0)
    cmd = np.broadcast_to(cmd, (n,)).copy()
    plant = ContactPlant(config, receivers, seed=seed, initial_grip_force_n=cmd)
    acc = OutcomeAccumulator(n, config.drop_distance_m)
    holds_at_release = np.zeros(n, dtype=bool)
    last_mode = np.full(n, -1, dtype=np.int8)

    def record() -> None:
        nonlocal holds_at_release, last_mode
        mode = np.asarray(plant.mode, dtype=np.int8)
        entered = (mode == Mode.RELEASE) & (last_mode != Mode.RELEASE)
        holds_at_release = np.where(entered, np.asarray(plant.holds, dtype=bool), holds_at_release)
        last_mode = mode
        acc.update(plant.time_s, plant.mode, plant.pull_x, plant.pull_y, plant.px, plant.py, plant.ay, plant.holds)

    record()
    for k in range(1, config.n_steps + 1):
        plant.step(cmd)
        if k % every == 0:
            cmd = np.broadcast_to(np.maximum(np.asarray(controller.step(plant.sensor_sample()), dtype=float), 0.0),
                                  (n,))
        if k % config.record_every == 0:
            record()
    out = acc.result()
    return AttributedOutcome(outcome=out, holds_at_release=holds_at_release & out.released)


def classify_drops(controller: AttributedOutcome, reference_dropped: np.ndarray) -> np.ndarray:
    """`DropClass` per episode (int8 array of shape (n,)); see the module docstring.

    Args:
        controller: the controller's attributed outcome.
        reference_dropped: drops of the max-hold reference on the same episodes.
    """
    o = controller.outcome
    ref = np.asarray(reference_dropped, dtype=bool)
    if ref.shape != o.dropped.shape:
        raise ValueError(f"reference drops of shape {ref.shape} for {len(o)} episodes")
    after_release = o.released & (o.drop_time_s >= o.release_time_s)
    let_go = after_release & controller.holds_at_release
    cls = np.where(ref, DropClass.UNAVOIDABLE,
                   np.where(let_go, DropClass.RECEIVER_LET_GO, DropClass.CONTROLLER))
    return np.where(o.dropped, cls, DropClass.NONE).astype(np.int8)


def paired_difference_ci(a_n: np.ndarray, b_n: np.ndarray, q: float, level: float = 0.95,
                         n_resamples: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """Difference of the `q`-th percentiles of paired samples a − b (same episodes), N, with a
    paired bootstrap confidence interval (`scipy.stats.bootstrap`, BCa, `level`).

    Returns (difference, CI low, CI high). A CI that contains 0 means the data do not show a
    difference at that level."""
    from scipy.stats import bootstrap

    a_n, b_n = np.asarray(a_n, dtype=float), np.asarray(b_n, dtype=float)
    if a_n.shape != b_n.shape or a_n.ndim != 1 or a_n.size < 2:
        raise ValueError("paired_difference_ci needs two 1-D samples of the same length (≥ 2)")

    def stat(x, y, axis=-1):
        return np.percentile(x, q, axis=axis) - np.percentile(y, q, axis=axis)

    diff = float(stat(a_n, b_n))
    shift = a_n - b_n
    if np.allclose(shift, shift[0], rtol=0.0, atol=1e-9):
        return diff, diff, diff  # a constant shift: every resample gives the same difference
    low = high = float("nan")
    for method in ("BCa", "percentile"):  # BCa is undefined on degenerate resamples
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = bootstrap((a_n, b_n), stat, paired=True, vectorized=True, n_resamples=n_resamples,
                            confidence_level=level, method=method, random_state=np.random.default_rng(seed))
        low, high = (float(v) for v in res.confidence_interval)
        if math.isfinite(low) and math.isfinite(high):
            break
    return diff, low, high


def paired_overshoot(a: BatchOutcome, b: BatchOutcome, taking: np.ndarray, ci: bool = False) -> dict:
    """Force overshoot of `a` and `b` on the taking episodes both handed over, N.

    Returns counts, the medians and p95 of each, and the median of the per-episode
    difference a − b. With `ci`: also the paired bootstrap 95 % CIs of the differences of
    the medians and of the p95s, on these episodes (``*_handed_over``) and on all taking
    episodes (``*_all_taking``: the benchmark table's population, drops included)."""
    both = np.asarray(taking, dtype=bool) & a.handed_over & b.handed_over
    oa, ob = a.force_overshoot_n[both], b.force_overshoot_n[both]
    if not both.any():
        return {"episodes": 0}
    out = {"episodes": int(both.sum()),
           "a_median_n": float(np.median(oa)), "a_p95_n": float(np.percentile(oa, 95)),
           "b_median_n": float(np.median(ob)), "b_p95_n": float(np.percentile(ob, 95)),
           "median_difference_n": float(np.median(oa - ob))}
    if ci:
        take = np.asarray(taking, dtype=bool)
        ta, tb = a.force_overshoot_n[take], b.force_overshoot_n[take]
        ok = np.isfinite(ta) & np.isfinite(tb)
        for label, (x, y) in (("handed_over", (oa, ob)), ("all_taking", (ta[ok], tb[ok]))):
            for name, q in (("median", 50.0), ("p95", 95.0)):
                d, lo, hi = paired_difference_ci(x, y, q)
                out[f"{name}_diff_{label}_n"] = d
                out[f"{name}_diff_{label}_ci_n"] = (lo, hi)
    return out
