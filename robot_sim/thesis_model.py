"""Thesis model mode: the object–gripper model of thesis §3.4.1 (eqs 3.1–3.4) as written.

This is the model the thesis's Matlab simulations of §3.5 use, kept so that Figures 20–23
can be reproduced. It is NOT a physical plant (see `robot_sim.contact` for that): it has no
velocity state, so the mode follows from the forces of the current step alone, and an
object in the slipping mode is never tracked out of the fingers.

Frames and signs (thesis Fig. 15): gripper frame, x along the pull toward the receiver,
y DOWN. The receiver pulls with F_p at angle φ below the x axis (φ > 0 pulls down).
The weight acting on the gripper is W_eff = W − (what the receiver supports).

At each step n, with grip force F_G[n] (N) applied, pull F_p[n] and weight W_eff[n]:

    applied load  L = (F_p cos φ, W_eff + F_p sin φ),   F_sum = |L|              (eq 3.2)
    release  (F_G = 0):          F_f = 0,     a = L / M                          (mode 3)
    grasp    (F_sum ≤ μ_s F_G):  F_f = L,     a = 0                              (eq 3.3)
    slipping (F_sum > μ_s F_G):  F_f = μ_k F_G along L, a = (F_sum − μ_k F_G)/M along L
                                                                                 (eq 3.4)
The wrist sensor reads the friction force, F_s = F_f (eq 3.5); the optical sensor reads a_y.
Eq 3.4 with a_y/a_x = tan θ puts the friction along the applied load, so the acceleration
is along L too. The grip force command for step n + 1 comes from the controller given the
step-n sensors. Diagnostics not in the thesis: the slip velocity and slide distance
obtained by integrating the slip-mode acceleration (zeroed while grasped), which show how
far an object "slipping" in this model would really have travelled.

Scenarios (§3.5): F_p ramps from 0 at `ramp_start_s` (1 s) to `pull_force_n` (2 N) at
`ramp_end_s` (1.5 s). Dropping: the pull is removed at `pull_end_s` (2.5 s) and the weight
is never supported. Taking: the receiver supports the weight, starting `weight_delay_s`
after the pull starts and ramping over `weight_transfer_s`. Optional white Gaussian noise
on the applied grip force and on the measured a_y at a given SNR (dB), relative to the
mean power of the same signal in the noiseless run of the same scenario (like Matlab's
`awgn(x, snr, 'measured')`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np

from handover_model.grip import GripController, Mode, SensorSample

STANDARD_GRAVITY_M_S2 = 9.81

__all__ = ["ThesisModelError", "ThesisRun", "ThesisScenario", "simulate", "step_model"]


class ThesisModelError(ValueError):
    """Bad scenario for the thesis model (the message names the field to fix)."""


@dataclass(frozen=True)
class ThesisScenario:
    """One §3.5 simulation run. Times in s, forces in N, angles in rad, mass in kg.

    Attributes:
        action: "taking" (the receiver supports the weight) or "dropping" (it does not, and
            the pull stops at `pull_end_s`).
        phi_rad: pull angle φ below the x axis.
        mass_kg, mu_static, mu_kinetic: object mass and friction of the whole grip
            (Table IV: 0.2 kg, 0.6, 0.5).
        pull_force_n: final pull F_p.
        ramp_start_s, ramp_end_s: F_p ramps linearly from 0 to `pull_force_n` in between.
        pull_end_s: dropping only: F_p becomes zero again from this time on.
        weight_delay_s: taking only: the weight support starts this long after `ramp_start_s`.
        weight_transfer_s: taking only: the support ramps from 0 to W over this time.
        duration_s, period_s: run length and step (the control period).
        grip_noise_snr_db: SNR of white Gaussian noise added to the applied grip force
            (None: no noise).
        accel_noise_snr_db: SNR of white Gaussian noise added to the measured a_y.
        noise_reference: what the SNR is relative to: "power", the mean square of the
            noiseless signal (Matlab `awgn(x, snr, 'measured')`), or "variance", its
            fluctuation about its mean (a much smaller noise for a grip force that sits
            near a constant).
        seed: random seed of the noise.
        initial_grip_force_n: F_G[0]; None asks the controller once with the object held at
            rest (F_s = (0, W), a_y = 0) and applies its answer.
        gravity_m_s2: g.
    """

    action: Literal["taking", "dropping"] = "dropping"
    phi_rad: float = 0.0
    mass_kg: float = 0.2
    mu_static: float = 0.6
    mu_kinetic: float = 0.5
    pull_force_n: float = 2.0
    ramp_start_s: float = 1.0
    ramp_end_s: float = 1.5
    pull_end_s: float = 2.5
    weight_delay_s: float = 0.05
    weight_transfer_s: float = 0.5
    duration_s: float = 4.0
    period_s: float = 0.01
    grip_noise_snr_db: float | None = None
    accel_noise_snr_db: float | None = None
    noise_reference: Literal["power", "variance"] = "power"
    seed: int = 0
    initial_grip_force_n: float | None = None
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2

    def __post_init__(self) -> None:
        if self.action not in ("taking", "dropping"):
            raise ThesisModelError(f"action must be 'taking' or 'dropping', got {self.action!r}")
        for name in ("mass_kg", "mu_static", "mu_kinetic", "duration_s", "period_s", "gravity_m_s2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ThesisModelError(f"{name} must be a positive finite number, got {value!r}")
        if self.mu_kinetic > self.mu_static:
            raise ThesisModelError(f"mu_kinetic ({self.mu_kinetic}) must not exceed mu_static ({self.mu_static})")
        if not (0.0 <= self.ramp_start_s <= self.ramp_end_s <= self.pull_end_s):
            raise ThesisModelError("need 0 <= ramp_start_s <= ramp_end_s <= pull_end_s")
        if not math.isfinite(self.phi_rad) or abs(self.phi_rad) > math.pi / 2.0:
            raise ThesisModelError(f"phi_rad must lie in [-pi/2, pi/2], got {self.phi_rad!r}")
        if not (math.isfinite(self.pull_force_n) and self.pull_force_n >= 0.0):
            raise ThesisModelError(f"pull_force_n must be >= 0, got {self.pull_force_n!r}")
        if self.weight_delay_s < 0.0 or self.weight_transfer_s < 0.0:
            raise ThesisModelError("weight_delay_s and weight_transfer_s must be >= 0")
        if self.noise_reference not in ("power", "variance"):
            raise ThesisModelError(f"noise_reference must be 'power' or 'variance', got {self.noise_reference!r}")
        if self.period_s > self.duration_s:
            raise ThesisModelError("period_s must not exceed duration_s")

    @property
    def weight_n(self) -> float:
        """W = M g, N."""
        return self.mass_kg * self.gravity_m_s2

    @property
    def n_steps(self) -> int:
        return int(round(self.duration_s / self.period_s)) + 1

    def time_s(self) -> np.ndarray:
        """Sample times, s, shape (n_steps,)."""
        return np.arange(self.n_steps) * self.period_s

    def pull_n(self, time_s: np.ndarray) -> np.ndarray:
        """Pull magnitude F_p(t), N."""
        t = np.asarray(time_s, dtype=float)
        ramp = self.ramp_end_s - self.ramp_start_s
        if ramp > 0.0:
            frac = np.clip((t - self.ramp_start_s) / ramp, 0.0, 1.0)
        else:
            frac = (t >= self.ramp_start_s).astype(float)
        pull = self.pull_force_n * frac
        if self.action == "dropping":
            pull = np.where(t >= self.pull_end_s, 0.0, pull)
        return pull

    def weight_on_gripper_n(self, time_s: np.ndarray) -> np.ndarray:
        """W_eff(t) = W minus what the receiver supports, N."""
        t = np.asarray(time_s, dtype=float)
        if self.action == "dropping":
            return np.full(t.shape, self.weight_n)
        start = self.ramp_start_s + self.weight_delay_s
        if self.weight_transfer_s > 0.0:
            supported = np.clip((t - start) / self.weight_transfer_s, 0.0, 1.0)
        else:
            supported = (t >= start).astype(float)
        return self.weight_n * (1.0 - supported)


def step_model(grip_force_n, pull_n, phi_rad, weight_n, mass_kg, mu_static, mu_kinetic):
    """One evaluation of eqs 3.1–3.5 for arrays of episodes.

    Arguments: applied grip force F_G (N, ≥ 0), pull F_p (N), angle φ (rad), weight on the
    gripper W_eff (N), mass M (kg), μ_s, μ_k; all broadcast together.

    Returns (mode, force_x_n, force_y_n, accel_x_m_s2, accel_y_m_s2): the mode (int8,
    `Mode` values), the wrist force F_s = F_f (eq 3.5) and the object acceleration.
    """
    grip = np.asarray(grip_force_n, dtype=float)
    load_x = np.asarray(pull_n, dtype=float) * np.cos(phi_rad)
    load_y = np.asarray(weight_n, dtype=float) + np.asarray(pull_n, dtype=float) * np.sin(phi_rad)
    load_x, load_y, grip = np.broadcast_arrays(load_x, load_y, grip)
    f_sum = np.hypot(load_x, load_y)
    released = grip <= 0.0
    grasped = ~released & (f_sum <= mu_static * grip)
    slipping = ~released & ~grasped

    safe_sum = np.where(f_sum > 0.0, f_sum, 1.0)
    unit_x, unit_y = load_x / safe_sum, load_y / safe_sum
    friction = np.where(grasped, f_sum, np.where(slipping, mu_kinetic * grip, 0.0))
    force_x = friction * unit_x
    force_y = friction * unit_y
    accel_mag = np.where(grasped, 0.0, (f_sum - friction)) / mass_kg
    mode = np.where(released, int(Mode.RELEASE), np.where(grasped, int(Mode.GRASP), int(Mode.SLIP))).astype(np.int8)
    return mode, force_x, force_y, accel_mag * unit_x, accel_mag * unit_y


@dataclass
class ThesisRun:
    """Result of `simulate`: arrays of shape (n_steps, n_episodes) unless noted.

    Attributes:
        scenarios: the scenarios, one per episode (column).
        time_s: (n_steps,) sample times, s.
        pull_n: pull F_p, N.
        weight_on_gripper_n: W_eff, N.
        grip_command_n: controller output applied at each step (before noise), N.
        grip_force_n: grip force the object feels (command plus noise, ≥ 0), N.
        force_x_n, force_y_n: wrist force F_s = F_f (eq 3.5), N.
        accel_x_m_s2, accel_y_m_s2: true object acceleration, m/s².
        accel_y_measured_m_s2: a_y as fed to the controller (with noise), m/s².
        mode: int8 `Mode` values (0 grasp, 1 slip, 2 release).
        slip_speed_m_s, slide_m: diagnostics from integrating the slip acceleration.
    """

    scenarios: list[ThesisScenario]
    time_s: np.ndarray
    pull_n: np.ndarray
    weight_on_gripper_n: np.ndarray
    grip_command_n: np.ndarray
    grip_force_n: np.ndarray
    force_x_n: np.ndarray
    force_y_n: np.ndarray
    accel_x_m_s2: np.ndarray
    accel_y_m_s2: np.ndarray
    accel_y_measured_m_s2: np.ndarray
    mode: np.ndarray
    slip_speed_m_s: np.ndarray
    slide_m: np.ndarray

    def column(self, episode: int) -> dict[str, np.ndarray]:
        """All per-step signals of one episode, name → (n_steps,) array."""
        names = (
            "pull_n", "weight_on_gripper_n", "grip_command_n", "grip_force_n", "force_x_n",
            "force_y_n", "accel_x_m_s2", "accel_y_m_s2", "accel_y_measured_m_s2", "mode",
            "slip_speed_m_s", "slide_m",
        )
        return {name: getattr(self, name)[:, episode] for name in names}


def _check_batch(scenarios: Sequence[ThesisScenario]) -> list[ThesisScenario]:
    batch = list(scenarios)
    if not batch:
        raise ThesisModelError("simulate needs at least one scenario")
    first = batch[0]
    for sc in batch[1:]:
        if (sc.n_steps, sc.period_s) != (first.n_steps, first.period_s):
            raise ThesisModelError("all scenarios of a batch must share duration_s and period_s")
    return batch


def _column(batch: list[ThesisScenario], name: str) -> np.ndarray:
    return np.array([getattr(sc, name) for sc in batch], dtype=float)


def _run(batch, controller: GripController, grip_noise_std_n, accel_noise_std_m_s2) -> ThesisRun:
    first = batch[0]
    n = len(batch)
    time = first.time_s()
    n_steps = time.size
    dt = first.period_s
    phi = _column(batch, "phi_rad")
    mass = _column(batch, "mass_kg")
    mu_s = _column(batch, "mu_static")
    mu_k = _column(batch, "mu_kinetic")
    weight = _column(batch, "weight_n")
    pull = np.stack([sc.pull_n(time) for sc in batch], axis=1)
    w_eff = np.stack([sc.weight_on_gripper_n(time) for sc in batch], axis=1)

    rngs = [np.random.default_rng(sc.seed) for sc in batch]
    grip_noise = np.stack([rng.standard_normal(n_steps) for rng in rngs], axis=1) * grip_noise_std_n
    accel_noise = np.stack([rng.standard_normal(n_steps) for rng in rngs], axis=1) * accel_noise_std_m_s2

    out = {
        name: np.zeros((n_steps, n))
        for name in (
            "grip_command_n", "grip_force_n", "force_x_n", "force_y_n", "accel_x_m_s2",
            "accel_y_m_s2", "accel_y_measured_m_s2", "slip_speed_m_s", "slide_m",
        )
    }
    mode_out = np.zeros((n_steps, n), dtype=np.int8)

    controller.reset(n)
    zeros = np.zeros(n)
    ones = np.ones(n, dtype=bool)
    initial = np.array([np.nan if sc.initial_grip_force_n is None else sc.initial_grip_force_n for sc in batch])
    if np.any(np.isnan(initial)):
        rest = SensorSample(
            time_s=-dt, force_x_n=zeros.copy(), force_y_n=weight.copy(), accel_y_m_s2=zeros.copy(),
            slip_velocity_x_m_s=zeros.copy(), slip_velocity_y_m_s=zeros.copy(), optical_valid=ones,
            grip_force_n=zeros.copy(),
        )
        primed = np.asarray(controller.step(rest), dtype=float)
        initial = np.where(np.isnan(initial), primed, initial)
    command = initial
    vel_x = np.zeros(n)
    vel_y = np.zeros(n)
    slide = np.zeros(n)
    for k in range(n_steps):
        applied = np.maximum(command + grip_noise[k], 0.0)
        mode, fx, fy, ax, ay = step_model(applied, pull[k], phi, w_eff[k], mass, mu_s, mu_k)
        moving = mode != int(Mode.GRASP)
        vel_x = np.where(moving, vel_x + ax * dt, 0.0)
        vel_y = np.where(moving, vel_y + ay * dt, 0.0)
        slide = slide + np.where(mode == int(Mode.SLIP), np.hypot(vel_x, vel_y) * dt, 0.0)
        ay_measured = ay + accel_noise[k]
        out["grip_command_n"][k] = command
        out["grip_force_n"][k] = applied
        out["force_x_n"][k] = fx
        out["force_y_n"][k] = fy
        out["accel_x_m_s2"][k] = ax
        out["accel_y_m_s2"][k] = ay
        out["accel_y_measured_m_s2"][k] = ay_measured
        out["slip_speed_m_s"][k] = np.hypot(vel_x, vel_y)
        out["slide_m"][k] = slide
        mode_out[k] = mode
        sample = SensorSample(
            time_s=float(time[k]), force_x_n=fx, force_y_n=fy, accel_y_m_s2=ay_measured,
            slip_velocity_x_m_s=vel_x, slip_velocity_y_m_s=vel_y, optical_valid=ones,
            grip_force_n=applied,
        )
        command = np.asarray(controller.step(sample), dtype=float)
    return ThesisRun(
        scenarios=batch, time_s=time, pull_n=pull, weight_on_gripper_n=w_eff, mode=mode_out, **out
    )


def _noise_std(power: np.ndarray, snr_db: np.ndarray) -> np.ndarray:
    """σ of white noise giving `snr_db` against a signal of mean power `power`."""
    std = np.sqrt(power / np.power(10.0, snr_db / 10.0))
    return np.where(np.isnan(snr_db), 0.0, std)


def simulate(scenarios: ThesisScenario | Sequence[ThesisScenario], controller: GripController) -> ThesisRun:
    """Run the thesis model for a batch of scenarios (vectorised over episodes).

    All scenarios share `duration_s` and `period_s`. The controller is reset for the batch
    and stepped once per step with a `SensorSample` (a noiseless reference run comes first
    when any scenario asks for noise, to measure the signal power the SNR refers to).
    """
    batch = _check_batch([scenarios] if isinstance(scenarios, ThesisScenario) else scenarios)
    grip_snr = np.array([np.nan if sc.grip_noise_snr_db is None else sc.grip_noise_snr_db for sc in batch])
    accel_snr = np.array([np.nan if sc.accel_noise_snr_db is None else sc.accel_noise_snr_db for sc in batch])
    zeros = np.zeros(len(batch))
    if np.all(np.isnan(grip_snr)) and np.all(np.isnan(accel_snr)):
        return _run(batch, controller, zeros, zeros)
    reference = _run(batch, controller, zeros, zeros)
    by_variance = np.array([sc.noise_reference == "variance" for sc in batch])
    # Reduce along contiguous rows so that a batch gives bit-identical powers to single runs.
    grip = np.ascontiguousarray(reference.grip_force_n.T)
    accel = np.ascontiguousarray(reference.accel_y_m_s2.T)
    grip_power = np.where(by_variance, np.var(grip, axis=1), np.mean(grip**2, axis=1))
    accel_power = np.where(by_variance, np.var(accel, axis=1), np.mean(accel**2, axis=1))
    return _run(batch, controller, _noise_std(grip_power, grip_snr), _noise_std(accel_power, accel_snr))

