"""Simulated joint position servo of the robot's arm (no bus, no clock: pure stepping).

Model per joint, with target q*, velocity feed-forward v_ff (the target's own rate, 0 when
not given), position q, time constant τ, velocity limit v_max and limits [q_lo, q_hi]:

    q̇ = clip(v_ff + (q* − q) / τ, −v_max, v_max)   (first-order lag with feed-forward)
    q ← clip(q + q̇ Δt, q_lo, q_hi)

With feed-forward a target streamed at 100 Hz is tracked with a lag of about v Δt/2 instead
of v τ, and a trajectory that comes to rest brings the arm to rest with it. The lag term is
integrated exactly (q* − q decays by exp(−Δt/τ) per step), so the servo is stable for any
Δt; the target is never extrapolated past the last command. Units: rad, rad/s, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from handover_model import robots
from handover_model.robots import JointLimits


#: Bound on the absolute rounding error of the computed 1 − exp(−dt/τ) (exp is within half
#: an ulp of a value ≤ 1, and the subtraction from 1 is exact there), with a margin.
DECAY_ROUNDING = 4.5e-16


@dataclass
class ArmState:
    """Joint positions (rad) and velocities (rad/s), in the arm's joint order."""

    position_rad: np.ndarray
    velocity_rad_s: np.ndarray


class SimulatedArm:
    """First-order-lag joint position servo with velocity and position limits.

    Args:
        time_constant_s: servo lag τ (s), > 0.
        limits: joint limits (default: the active arm's).
        initial_position_rad: start posture (default: the active arm's home posture).
    """

    def __init__(
        self,
        time_constant_s: float = 0.05,
        limits: JointLimits | None = None,
        initial_position_rad: np.ndarray | None = None,
    ) -> None:
        if not time_constant_s > 0:
            raise ValueError(f"servo time constant must be > 0 s, got {time_constant_s}")
        self.time_constant_s = float(time_constant_s)
        self.limits = limits if limits is not None else robots.arm_model().limits
        start = np.array(
            robots.active().home_rad if initial_position_rad is None else initial_position_rad, dtype=float
        )
        start = np.clip(start, self.limits.lower_rad, self.limits.upper_rad)
        self.state = ArmState(position_rad=start, velocity_rad_s=np.zeros_like(start))
        self.target_rad = start.copy()
        self.feedforward_rad_s = np.zeros_like(start)

    def set_target(self, target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None = None) -> None:
        """Set the servo target (rad, clipped to the joint limits) and its rate (rad/s)."""
        self.target_rad = np.clip(
            np.asarray(target_rad, dtype=float), self.limits.lower_rad, self.limits.upper_rad
        )
        if feedforward_rad_s is None:
            self.feedforward_rad_s = np.zeros_like(self.target_rad)
        else:
            self.feedforward_rad_s = np.clip(np.asarray(feedforward_rad_s, dtype=float),
                                             -self.limits.velocity_rad_s, self.limits.velocity_rad_s)

    def hold(self) -> None:
        """Hold the current position: the target becomes where the arm is now, at rest."""
        self.target_rad = self.state.position_rad.copy()
        self.feedforward_rad_s = np.zeros_like(self.target_rad)

    def still_for_dt_up_to_s(self) -> float:
        """The longest step (s) after which the state is still bit for bit what it is now,
        proven from the servo's equations: 0.0 when none is (the arm moves, or the
        feed-forward is not zero). An arm settled a few units in the last place short of its
        target (the lag term then rounds away) stays put for any dt up to the bound: each
        joint's step error × (1 − exp(−dt/τ)) stays below 0.45 of the gap to its nearest
        neighbouring float, under the 0.5 at which q + step could round away from q, with
        the computed decay's own rounding (1 − exp(x) is off by up to 1.1e-16 in absolute
        terms, which matters for a tiny dt against a large error) allowed for.
        Valid while the state, the target and the feed-forward are unchanged."""
        q = self.state.position_rad
        if self.feedforward_rad_s.any() or self.state.velocity_rad_s.any():
            return 0.0
        if np.signbit(self.state.velocity_rad_s).any() or not np.all((q >= self.limits.lower_rad)
                                                                       & (q <= self.limits.upper_rad)):
            return 0.0  # a −0.0 velocity would become +0.0; a position outside would be clipped
        bound = math.inf
        gaps = np.minimum(np.nextafter(q, np.inf) - q, q - np.nextafter(q, -np.inf))
        for error, gap in zip((self.target_rad - q).tolist(), gaps.tolist()):
            if error == 0.0:
                continue  # q + (±0.0) is q for any dt (a −0.0 position fails the caller's check)
            ratio = 0.45 * gap / abs(error) - DECAY_ROUNDING
            if ratio <= 0.0:
                return 0.0  # no dt short of a rounding's worth
            if not ratio < 1.0:
                continue
            bound = min(bound, -self.time_constant_s * math.log1p(-ratio))
        return bound

    def step(self, dt_s: float) -> ArmState:
        """Advance the servo by `dt_s` seconds and return the new state."""
        if dt_s <= 0:
            return self.state
        q = self.state.position_rad
        error = self.target_rad - q
        # The lag term is the exact mean velocity of a first-order decay over dt; the
        # feed-forward adds the commanded rate. The target itself is never extrapolated past
        # the last command (a stale command must not carry the arm on).
        decay = 1.0 - np.exp(-dt_s / self.time_constant_s)
        velocity = self.feedforward_rad_s + error * decay / dt_s
        velocity = np.clip(velocity, -self.limits.velocity_rad_s, self.limits.velocity_rad_s)
        new_q = np.clip(q + velocity * dt_s, self.limits.lower_rad, self.limits.upper_rad)
        self.state = ArmState(position_rad=new_q, velocity_rad_s=(new_q - q) / dt_s)
        return self.state
