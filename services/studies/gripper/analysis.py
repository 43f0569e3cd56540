"""Analysis of the fail-safe law (thesis §3.4.3–3.4.4): thresholds, conditions, φ_max.

Frames and signs (thesis Fig. 15): gripper frame, x along the pull toward the receiver,
y DOWN; the pull F_p acts at angle φ below the x axis (φ > 0 pulls downward, φ < 0
upward). W = M g is the object's weight (N).

- Start force threshold F_ST(φ) (eq 3.12): the pull at which the grasp turns into slip,
  from F_sum = μ_s F_G with F_G from eq 3.7 in the grasp mode. The printed equation drops
  a square: the left side is F_sum = √(F_ST² + W² + 2 W F_ST sin φ) (eq 3.2). Both forms
  are available (`printed_equation=True` gives the printed one, for comparison only).
- Stable force threshold F_BT(φ): the smallest pull above which the slip-mode pole of the
  grip-force recursion satisfies |a| ≤ 1, from eq 3.16 (no integrator) or eq 3.20 (with
  the integrator k_i).
- Rest condition (eq 3.9), tolerated downward acceleration (eq 3.11), and φ_max, the
  steepest downward pull at which the receiver can still make the object slip.

Roots are found with scipy (`brentq` after bracketing); the closed forms used in the tests
come from squaring the equations (quadratics), an independent route.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from services.gripper.controllers.fail_safe import FailSafeParams
from services.gripper.errors import GripperError

STANDARD_GRAVITY_M_S2 = 9.81

__all__ = [
    "ThesisPlant",
    "TABLE_IV_PLANT",
    "fst_residual_n",
    "phi_max_for_pull_rad",
    "phi_max_rad",
    "rest_condition_alpha_min",
    "rest_condition_holds",
    "slip_pole",
    "start_force_threshold_n",
    "stable_force_threshold_n",
    "tolerated_accel_m_s2",
]


@dataclass(frozen=True)
class ThesisPlant:
    """Object and friction of the thesis model.

    Attributes:
        mass_kg: object mass M, kg.
        mu_static: μ_s, static friction coefficient of the whole grip (both pads).
        mu_kinetic: μ_k, kinetic friction coefficient of the whole grip.
        gravity_m_s2: g, m/s².
    """

    mass_kg: float = 0.2
    mu_static: float = 0.6
    mu_kinetic: float = 0.5
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2

    def __post_init__(self) -> None:
        for name in ("mass_kg", "mu_static", "mu_kinetic", "gravity_m_s2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise GripperError(f"plant {name} must be a positive finite number, got {value!r}")
        if self.mu_kinetic > self.mu_static:
            raise GripperError(
                f"kinetic friction μ_k = {self.mu_kinetic} exceeds static μ_s = {self.mu_static}: check the plant"
            )

    @property
    def weight_n(self) -> float:
        """W = M g, N."""
        return self.mass_kg * self.gravity_m_s2


#: Table IV: M = 0.2 kg, μ_s = 0.6, μ_k = 0.5.
TABLE_IV_PLANT = ThesisPlant()


# --------------------------------------------------------------------------- performance conditions


def rest_condition_alpha_min(fs: FailSafeParams, plant: ThesisPlant) -> float:
    """Smallest α that holds the object at rest (eq 3.9): 1/μ_s + F_margin/W."""
    return 1.0 / plant.mu_static + fs.f_margin_n / plant.weight_n


def rest_condition_holds(fs: FailSafeParams, plant: ThesisPlant) -> bool:
    """Eq 3.9: μ_s F_G ≥ W at rest, with F_G = α W − F_margin (eq 3.7)."""
    return fs.alpha >= rest_condition_alpha_min(fs, plant)


def tolerated_accel_m_s2(fs: FailSafeParams) -> float:
    """Largest downward acceleration tolerated in the release mode, F_margin/β (eq 3.11), m/s²."""
    if fs.beta <= 0.0:
        return math.inf
    return fs.f_margin_n / fs.beta


# --------------------------------------------------------------------------- start force threshold


def fst_residual_n(pull_n, phi_rad, fs: FailSafeParams, plant: ThesisPlant, printed_equation: bool = False):
    """F_sum − μ_s F_G in the grasp mode at pull F_p (N) and angle φ (rad): eq 3.12 as a residual.

    F_G is the unclamped grasp-mode law α F_sy − γ F_sx − F_margin with F_sy = W + F_p sin φ,
    F_sx = F_p cos φ (eqs 3.3, 3.5, 3.7). Negative: still grasped; zero: at F_ST.
    `printed_equation=True` uses the left side as printed, √(F_p + W² + 2 W F_p sin φ).
    """
    f = np.asarray(pull_n, dtype=float)
    w = plant.weight_n
    s, c = np.sin(phi_rad), np.cos(phi_rad)
    first = f if printed_equation else f * f
    f_sum = np.sqrt(np.maximum(first + w * w + 2.0 * w * f * s, 0.0))
    grip = fs.alpha * (w + f * s) - fs.gamma * f * c - fs.f_margin_n
    return f_sum - plant.mu_static * grip


def _start_force_threshold_scalar(phi_rad: float, fs, plant, printed_equation: bool, max_pull_n: float) -> float:
    def g(f: float) -> float:
        return float(fst_residual_n(f, phi_rad, fs, plant, printed_equation))

    if g(0.0) >= 0.0:
        return 0.0  # the rest condition fails: the object slips without any pull
    upper = 1.0
    while g(upper) < 0.0:
        if upper >= max_pull_n:
            return math.inf
        upper = min(2.0 * upper, max_pull_n)
    return float(brentq(g, 0.0, upper, xtol=1e-12, rtol=1e-12))


def start_force_threshold_n(
    phi_rad,
    fs: FailSafeParams,
    plant: ThesisPlant = TABLE_IV_PLANT,
    printed_equation: bool = False,
    max_pull_n: float = 1e4,
):
    """Start force threshold F_ST(φ), N (eq 3.12 with the square restored).

    The smallest pull F_p ≥ 0 at angle φ (rad, scalar or array) at which F_sum reaches
    μ_s F_G. Returns 0 where the rest condition fails (the object slips unpulled) and inf
    where no pull up to `max_pull_n` makes it slip (φ beyond φ_max).
    """
    phi = np.asarray(phi_rad, dtype=float)
    out = np.array(
        [_start_force_threshold_scalar(float(p), fs, plant, printed_equation, max_pull_n) for p in phi.ravel()]
    ).reshape(phi.shape)
    return float(out) if out.ndim == 0 else out


def _slip_slope(phi_rad: float, fs: FailSafeParams, plant: ThesisPlant) -> float:
    """d(residual)/dF_p for large F_p: 1 − μ_s (α sin φ − γ cos φ). ≤ 0: no pull makes it slip."""
    return 1.0 - plant.mu_static * (fs.alpha * math.sin(phi_rad) - fs.gamma * math.cos(phi_rad))


def phi_max_rad(fs: FailSafeParams, plant: ThesisPlant = TABLE_IV_PLANT) -> float:
    """φ_max (rad): the steepest downward pull angle at which some finite pull makes the
    object slip, i.e. where F_ST(φ) → ∞.

    The grasp residual of eq 3.12 is convex in F_p and negative at F_p = 0 (rest condition),
    so a root exists exactly while its slope at large pull, 1 − μ_s (α sin φ − γ cos φ),
    is positive; φ_max is the zero of that slope on [−90°, 90°] (scipy brentq). Returns
    +π/2 if every downward angle allows a slip.
    """
    lo, hi = -math.pi / 2.0, math.pi / 2.0
    if _slip_slope(hi, fs, plant) > 0.0:
        return hi
    if _slip_slope(lo, fs, plant) <= 0.0:
        raise GripperError("no pull angle lets the object slip: check α, γ and μ_s")
    return float(brentq(lambda p: _slip_slope(p, fs, plant), lo, hi, xtol=1e-14))


def phi_max_for_pull_rad(
    max_pull_n: float, fs: FailSafeParams, plant: ThesisPlant = TABLE_IV_PLANT
) -> float:
    """The steepest downward pull angle (rad) at which F_ST(φ) ≤ `max_pull_n` (N).

    A practical φ_max for a receiver who pulls at most `max_pull_n`. F_ST rises with φ
    toward the asymptote at `phi_max_rad`; the crossing is found with brentq.
    """
    if not (math.isfinite(max_pull_n) and max_pull_n > 0.0):
        raise GripperError(f"max_pull_n must be a positive finite force in N, got {max_pull_n!r}")
    hi = phi_max_rad(fs, plant) - 1e-9
    lo = -math.pi / 2.0 + 1e-9

    def h(phi: float) -> float:
        return min(start_force_threshold_n(phi, fs, plant), 1e9) - max_pull_n

    if h(lo) > 0.0:
        raise GripperError(f"even an upward pull needs more than {max_pull_n} N to make the object slip")
    if h(hi) <= 0.0:
        return hi
    return float(brentq(h, lo, hi, xtol=1e-10))


# --------------------------------------------------------------------------- stability (F_BT)


def slip_pole(pull_n, phi_rad, fs: FailSafeParams, plant: ThesisPlant = TABLE_IV_PLANT, with_integrator: bool = True):
    """Pole a of the slip-mode recursion F_G[n+1] = a F_G[n] + b.

    Eq 3.16 (no integrator): a = μ_k/F_sum [(W + F_p sin φ)(α − β/M) − γ F_p cos φ].
    Eq 3.20 (integrator):    a = k_i · (eq 3.16) + (1 − k_i).
    `pull_n` in N, `phi_rad` in rad (broadcast together).
    """
    f = np.asarray(pull_n, dtype=float)
    phi = np.asarray(phi_rad, dtype=float)
    w = plant.weight_n
    load_y = w + f * np.sin(phi)
    load_x = f * np.cos(phi)
    f_sum = np.hypot(load_x, load_y)
    a0 = plant.mu_kinetic / f_sum * (load_y * (fs.alpha - fs.beta / plant.mass_kg) - fs.gamma * load_x)
    if with_integrator:
        return fs.k_i * a0 + (1.0 - fs.k_i)
    return a0


def _stable_force_threshold_scalar(phi_rad: float, fs, plant, with_integrator: bool, max_pull_n: float,
                                   n_grid: int) -> float:
    def excess(f):
        return np.abs(slip_pole(f, phi_rad, fs, plant, with_integrator)) - 1.0

    # Pull where F_sum = 0 (φ = −90°, F_p = W) makes the pole undefined: avoid exact hits.
    grid = np.concatenate([[0.0], np.geomspace(1e-6, max_pull_n, n_grid)])
    values = excess(grid)
    if values[-1] > 0.0:
        return math.inf
    unstable = np.flatnonzero(values > 0.0)
    if unstable.size == 0:
        return 0.0
    i = int(unstable[-1])
    return float(brentq(lambda f: float(excess(f)), grid[i], grid[i + 1], xtol=1e-12, rtol=1e-12))


def stable_force_threshold_n(
    phi_rad,
    fs: FailSafeParams,
    plant: ThesisPlant = TABLE_IV_PLANT,
    with_integrator: bool = True,
    max_pull_n: float = 1e3,
    n_grid: int = 4000,
):
    """Stable force threshold F_BT(φ), N: the smallest pull F_p such that the slip-mode pole
    satisfies |a| ≤ 1 for every pull from F_p up to `max_pull_n` (eq 3.18 with 3.16 or 3.20).

    Returns 0 when the recursion is stable for every pull (the thesis's claim for the
    integrator, Fig. 19b) and inf when it is unstable even at `max_pull_n`. The last sign
    change of |a| − 1 on a geometric grid is refined with brentq.
    """
    phi = np.asarray(phi_rad, dtype=float)
    out = np.array(
        [
            _stable_force_threshold_scalar(float(p), fs, plant, with_integrator, max_pull_n, n_grid)
            for p in phi.ravel()
        ]
    ).reshape(phi.shape)
    return float(out) if out.ndim == 0 else out
