"""The slip-guarded load-share release controller (SG), our own law, and its presets.

It holds in proportion to the load the gripper still carries, scaled by the measured weight;
raises (and remembers) the grip whenever the object slides while loaded, and grips at once
when the object falls; see `SlipGuardParams` for the law. Forces in N, speeds in m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from handover_model.grip import SensorSample
from services.gripper.controllers.common import (
    ABSOLUTE_MAX_GRIP_FORCE_N,
    DEFAULT_PERIOD_S,
    DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2,
    BaseController,
    as_episodes,
    check_finite,
    check_max_force,
    estimate_mode,
)
from services.gripper.errors import GripperError


@dataclass(frozen=True)
class SlipGuardParams:
    """Parameters of the slip-guarded load-share controller (SG), our own law.

    Notation per episode, control step n of period T: W0 = F_sy of the first sample (the
    object's weight as the wrist feels it), s = F_sy / W0 (share of the load still on the
    gripper), v = (v_x, v_y) the optical slip velocity (y down), valid where the sensor
    sees the object.

        slide memory: while valid and |v| > v_th, if s_prev > s_guard:  s = max(s, s_prev)
                      (s_prev: the share one step before the slide began)
        demand[n] = g[n] · F_hold · clip((s − s_rel) / (1 − s_rel), 0, s_cap),
        F_hold    = min(c_hold · W0 + F_min, F_hold_max)
        g[n+1]    = min(g[n] + k_g T |v| / v_th, g_max)    if valid, |v| > v_th and s > s_guard
        catch:      demand = max(demand, g F_hold)          if valid, v_y > v_th and v_y > κ |v_x|
        F_G[n+1]  = demand                                  if demand ≥ F_G[n]   (grip up at once)
                  = F_G[n] + k_down (demand − F_G[n])       otherwise            (ease off)
        F_G       = 0                                       once F_G < F_eps (then ≥ 0 N only on a catch)

    In words: hold in proportion to the load the gripper still carries (like HI, but
    scaled by the measured weight, not a fixed 15 N); release when the receiver carries
    all but s_rel of it; whenever the object slides while the gripper still carries the
    load (s > s_guard), raise the grip and *remember* it (g never decreases: the
    friction the object needs was learned); and whenever the object moves down more
    steeply than any receiver pull (v_y > κ |v_x|, κ = 1.5 ≈ 56° below horizontal), it is
    falling, not being taken: grip at once, also after a release. The slip velocity, not
    the acceleration, sees an object that slides at constant speed.

    The slide memory (`slip_share_memory`, on by default since version 2): while the object
    slides, the wrist reads the pads' *kinetic friction*, which points along the slide, not
    the load; a sideways slide (a receiver hooking and pulling the object without carrying
    it) makes F_sy, and so s, fall as if the receiver had taken the weight, and version 1
    released into the fall. Version 2 keeps the share seen before the slide (one step back,
    since the optical speed lags the wrist by up to a report) while the gripper carried the
    load then. Version 1 = `slip_share_memory=False, release_share=0.3, ease_off=0.3`.

    Version 3 (the defaults; v2 is the preset "SG-v2" of `SG_PRESETS`) moves the grip from
    where it raised the force overshoot to where it saves drops, tuned on seed 1000 only:
    - hold cap F_hold_max = 20 N (v2: none): the heaviest objects (up to 0.6 kg) were held with
      up to 4 · 5.9 + 1 = 24.5 N; a high-friction heavy object then needs a large pull to come
      free while the 50 N/s actuator ramps the grip down (≈ 0.5 s from 24.5 N), and those
      handovers made SG's overshoot tail. Above the cap a slippery heavy object relies on the
      slip guard (g grows with the slide), which scales the capped hold.
    - s_cap = 1 (v2: 3): the demand no longer grows above the hold when F_sy rises above the
      rest weight. A receiver pulling *downward* while taking the object raised F_sy, so v2
      gripped up to 3× harder against exactly the pull that takes it.
    - c_hold = 5.5 (v2: 4): a firmer hold of light and medium objects (below the cap), which
      buys back the drops the two changes above cost (dropping receivers that pull downward,
      heavy slippery objects), where overshoot is low to begin with.

    Attributes:
        hold_per_weight: c_hold (1/μ the grip holds without adapting), dimensionless.
        min_hold_force_n: F_min, N.
        max_hold_force_n: F_hold_max, N: largest rest hold (> F_min; inf = no cap, as in v2);
            the slip guard's gain g and the catch multiply the capped hold.
        release_share: s_rel, load share at which the demand reaches zero.
        share_cap: s_cap, largest share the demand follows (downward pulls), dimensionless.
        guard_share: s_guard, the slip guard adapts g only above this load share.
        slip_speed_threshold_m_s: v_th, m/s (one optical count per 10 ms ≈ 6.4 mm/s).
        adapt_rate_per_s: k_g, 1/s (growth of g per second at |v| = v_th).
        fall_steepness: κ, v_y > κ |v_x| counts as falling.
        resist_per_force: while s > s_guard the demand is at least g times this times
            |F_s| (0 = off, the default).
        slip_share_memory: keep the pre-slide load share during a slide (see above).
        ease_off: k_down per control step (0 < k_down ≤ 1; 1 = follow the demand at once).
        release_epsilon_n: F_eps, N.
        max_grip_force_n: F_max, N (≤ 140 N).
    """

    hold_per_weight: float = 5.5
    min_hold_force_n: float = 1.0
    release_share: float = 0.5
    share_cap: float = 1.0
    guard_share: float = 0.8
    slip_speed_threshold_m_s: float = 0.005
    adapt_rate_per_s: float = 20.0
    fall_steepness: float = 1.5
    resist_per_force: float = 0.0
    slip_share_memory: bool = True
    ease_off: float = 1.0
    release_epsilon_n: float = 0.2
    max_grip_force_n: float = ABSOLUTE_MAX_GRIP_FORCE_N
    max_hold_force_n: float = 20.0

    def __post_init__(self) -> None:
        for name in ("hold_per_weight", "share_cap", "slip_speed_threshold_m_s", "ease_off"):
            check_finite(name, getattr(self, name), positive=True)
        for name in ("min_hold_force_n", "guard_share", "adapt_rate_per_s", "fall_steepness", "resist_per_force",
                     "release_epsilon_n"):
            check_finite(name, getattr(self, name), nonneg=True)
        check_finite("release_share", self.release_share, nonneg=True)
        if not self.release_share < 1.0:
            raise GripperError(f"release_share must be < 1, got {self.release_share}")
        if self.ease_off > 1.0:
            raise GripperError(f"ease_off must be in (0, 1], got {self.ease_off}")
        check_max_force(self.max_grip_force_n)
        if not self.max_hold_force_n > self.min_hold_force_n:
            raise GripperError(f"max_hold_force_n must be > min_hold_force_n ({self.min_hold_force_n} N), "
                               f"got {self.max_hold_force_n}")

    def hold_force_n(self, rest_load_n):
        """F_hold = min(c_hold · W0 + F_min, F_hold_max), N, per episode (W0 in N)."""
        return np.minimum(self.hold_per_weight * np.asarray(rest_load_n, dtype=float) + self.min_hold_force_n,
                          self.max_hold_force_n)

    def load_level(self, share):
        """Demand per unit hold for a load share s: clip((s − s_rel)/(1 − s_rel), 0, s_cap)."""
        return np.clip((np.asarray(share, dtype=float) - self.release_share) / (1.0 - self.release_share),
                       0.0, self.share_cap)


class SlipGuardController(BaseController):
    """Slip-guarded load-share controller (SG), vectorised over episodes; see
    `SlipGuardParams` for the law."""

    def __init__(self, params: SlipGuardParams | None = None, period_s: float = DEFAULT_PERIOD_S,
                 slip_accel_threshold_m_s2: float = DEFAULT_SLIP_ACCEL_THRESHOLD_M_S2) -> None:
        super().__init__(period_s)
        self.params = params or SlipGuardParams()
        self.slip_accel_threshold_m_s2 = slip_accel_threshold_m_s2

    def reset(self, n_episodes: int = 1) -> None:
        self._reset_common(n_episodes)
        self.grip_force_n = np.zeros(self.n_episodes)
        self.gain = np.ones(self.n_episodes)
        self.rest_load_n: np.ndarray | None = None
        self.share_before_slip = np.ones(self.n_episodes)
        self._previous_share = np.ones(self.n_episodes)

    def step(self, sample: SensorSample) -> np.ndarray:
        self._require_reset(sample)
        p, n, dt = self.params, self.n_episodes, self.period_s
        fx = as_episodes(sample.force_x_n, n, "force_x_n")
        fy = as_episodes(sample.force_y_n, n, "force_y_n")
        vx = as_episodes(sample.slip_velocity_x_m_s, n, "slip_velocity_x_m_s")
        vy = as_episodes(sample.slip_velocity_y_m_s, n, "slip_velocity_y_m_s")
        valid = np.broadcast_to(np.asarray(sample.optical_valid, dtype=bool), (n,))
        if self.rest_load_n is None:
            if np.any(fy <= 0.0):
                raise GripperError(
                    "SG controller: the first sample shows no downward load (F_sy <= 0); "
                    "start it while the gripper holds the object"
                )
            self.rest_load_n = fy.copy()
            self.grip_force_n = np.minimum(p.hold_force_n(self.rest_load_n), p.max_grip_force_n)
        w0 = self.rest_load_n
        share = fy / w0
        speed = np.hypot(vx, vy)
        slipping = valid & (speed > p.slip_speed_threshold_m_s)
        hold = p.hold_force_n(w0)
        if p.slip_share_memory:
            # While the object slides the wrist reads kinetic friction along the slide, not the
            # load: keep the share seen one step before the slide began (if the gripper carried
            # the load then), so a slide cannot look like a receiver taking the weight.
            self.share_before_slip = np.where(slipping, self.share_before_slip, self._previous_share)
            self._previous_share = share
            loaded = slipping & (self.share_before_slip > p.guard_share)
            share = np.where(loaded, np.maximum(share, self.share_before_slip), share)
        adapt = slipping & (share > p.guard_share)
        g_max = p.max_grip_force_n / hold
        self.gain = np.where(adapt,
                             np.minimum(self.gain + p.adapt_rate_per_s * dt * speed / p.slip_speed_threshold_m_s,
                                        g_max),
                             self.gain)
        level = p.load_level(share)
        guarding = share > p.guard_share
        resist = np.where(guarding, p.resist_per_force * np.hypot(fx, fy), 0.0)
        demand = self.gain * np.maximum(hold * level, resist)
        falling = valid & (vy > p.slip_speed_threshold_m_s) & (vy > p.fall_steepness * np.abs(vx))
        demand = np.where(falling, np.maximum(demand, self.gain * hold), demand)
        grip = np.where(demand >= self.grip_force_n, demand,
                        self.grip_force_n + p.ease_off * (demand - self.grip_force_n))
        grip = np.where(grip < p.release_epsilon_n, 0.0, grip)
        self.grip_force_n = np.clip(grip, 0.0, p.max_grip_force_n)
        self.mode = estimate_mode(self.grip_force_n, sample, n, self.slip_accel_threshold_m_s2,
                                   p.slip_speed_threshold_m_s)
        return self.grip_force_n.copy()


#: Named SG parameter sets: "SG" is the current version (3, the `SlipGuardParams` defaults);
#: "SG-v2" the previous one, kept so the comparison can be re-run.
SG_PRESETS: dict[str, SlipGuardParams] = {
    "SG": SlipGuardParams(),
    "SG-v2": SlipGuardParams(hold_per_weight=4.0, max_hold_force_n=math.inf, share_cap=3.0),
}
