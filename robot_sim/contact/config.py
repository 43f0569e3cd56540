"""Typed, validated parameters of the contact simulator (SI units, gripper frame).

Gripper frame: x toward the receiver, y DOWN (thesis Fig. 15). Defaults follow the thesis
where it gives a number (M = 0.2 kg, μ_s = 0.6, μ_k = 0.5 from Table IV; spring k = 5 N/cm,
25 Hz gripper position loop and 100 Hz wrist F/T from §3.6; ADNS-2051 optical sensor) and
are otherwise stated as assumptions next to the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

GRAVITY_M_S2 = 9.81


class ContactSimError(Exception):
    """Root of every error of the contact simulator (the message says what to check)."""


def _check(cond: bool, what: str) -> None:
    if not cond:
        raise ContactSimError(f"invalid contact-sim parameter: {what}")


def _finite(obj) -> None:
    for f in fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, float) and not math.isfinite(v) and not f.name.endswith("_or_inf"):
            raise ContactSimError(f"invalid contact-sim parameter: {type(obj).__name__}.{f.name} must be finite, "
                                  f"got {v}")


@dataclass(frozen=True)
class ObjectParams:
    """The held object and the friction pads.

    mass_kg: object mass M (thesis Table IV: 0.2 kg).
    mu_static, mu_kinetic: total friction coefficients of the two pads together (thesis:
        "μ_s is twice the coefficient of one finger"); μ_k ≤ μ_s.
    pad_extent_x_m: how far the object can slide along ±x before it leaves the pads.
    pad_extent_y_m: how far it can slide along ±y before it leaves the pads (assumption:
        3 cm, a 6 cm pad over a box face).
    optical_face_x_m, optical_face_y_m: half-extent of the object face over the optical
        sensor along x and y: beyond it the sensor sees no surface.
    """

    mass_kg: float = 0.2
    mu_static: float = 0.6
    mu_kinetic: float = 0.5
    pad_extent_x_m: float = 0.04
    pad_extent_y_m: float = 0.03
    optical_face_x_m: float = 0.03
    optical_face_y_m: float = 0.08

    def __post_init__(self) -> None:
        _finite(self)
        _check(self.mass_kg > 0, f"mass_kg must be > 0, got {self.mass_kg}")
        _check(0 < self.mu_kinetic <= self.mu_static,
               f"need 0 < mu_kinetic <= mu_static, got {self.mu_kinetic}, {self.mu_static}")
        for n in ("pad_extent_x_m", "pad_extent_y_m", "optical_face_x_m", "optical_face_y_m"):
            _check(getattr(self, n) > 0, f"{n} must be > 0")

    @property
    def weight_n(self) -> float:
        """W = M g (N)."""
        return self.mass_kg * GRAVITY_M_S2


@dataclass(frozen=True)
class GripperParams:
    """Gripper actuator: thesis eq 3.21 spring and the thesis robot's position loop.

    spring_n_per_m: k of eq 3.21 (5 N/cm = 500 N/m).
    loop_rate_hz: the position loop latches a new target at this rate (25 Hz, §3.6).
    lag_time_constant_s: first-order lag of the finger toward its target (assumption).
    speed_limit_m_s: finger speed limit (assumption: 0.1 m/s, i.e. 50 N/s through the spring).
    open_gap_m: how far behind the contact position x0 the finger goes for a zero-force
        command (0 = thesis: F_G = 0 means touching with no force; > 0 opens the hand).
    max_force_n: commands are clamped to [0, max_force_n] (ISO/TS 15066 hand limit 140 N).
    min_force_n: the softest grip the gripper holds (N): a command in (0, min_force_n) grips
        with min_force_n (a Robotiq 2F-85 cannot press with less than 20 N); 0 opens.
    """

    spring_n_per_m: float = 500.0
    loop_rate_hz: float = 25.0
    lag_time_constant_s: float = 0.02
    speed_limit_m_s: float = 0.1
    open_gap_m: float = 0.0
    max_force_n: float = 140.0
    min_force_n: float = 0.0

    def __post_init__(self) -> None:
        _finite(self)
        _check(self.spring_n_per_m > 0, "spring_n_per_m must be > 0")
        _check(self.loop_rate_hz > 0, "loop_rate_hz must be > 0")
        _check(self.lag_time_constant_s >= 0, "lag_time_constant_s must be >= 0")
        _check(self.speed_limit_m_s > 0, "speed_limit_m_s must be > 0")
        _check(self.open_gap_m >= 0, "open_gap_m must be >= 0")
        _check(0 < self.max_force_n <= 140.0, "max_force_n must be in (0, 140] N")
        _check(0 <= self.min_force_n < self.max_force_n, "min_force_n must be in [0, max_force_n) N")

    @property
    def force_rate_n_per_s(self) -> float:
        """Fastest change of the grip force, N/s: the spring times the finger speed limit
        (50 N/s by default). Large force steps change at this rate; small ones follow the
        finger's first-order lag."""
        return self.spring_n_per_m * self.speed_limit_m_s

    def with_rates(self, force_rate_n_per_s: float, loop_rate_hz: float) -> "GripperParams":
        """This gripper with another force rate (N/s, through the finger speed limit) and
        position-loop rate (Hz); the spring, lag, gap and force limit stay."""
        _check(math.isfinite(force_rate_n_per_s) and force_rate_n_per_s > 0,
               f"force rate must be > 0 N/s, got {force_rate_n_per_s}")
        return replace(self, speed_limit_m_s=force_rate_n_per_s / self.spring_n_per_m, loop_rate_hz=loop_rate_hz)


@dataclass(frozen=True)
class SensorParams:
    """Wrist F/T sensor and ADNS-2051-class optical sensor.

    ft_rate_hz: F/T sample rate (100 Hz, §3.6). ft_noise_std_n: white noise per axis (N).
    ft_bias_std_n: per-episode bias per axis drawn from N(0, σ) (N); ft_bias_n fixed part.
    optical_counts_per_m: resolution (400 cpi = 15748 counts/m).
    optical_frame_rate_hz: sensor frame rate (ADNS-2051: 1500 frames/s).
    optical_max_disp_per_frame_m: largest displacement one frame can track; with the frame
        rate this gives the speed limit (ADNS-2051: 14 in/s ≈ 0.36 m/s at 1500 fps).
    optical_report_rate_hz: how often the host reads the delta registers (100 Hz default).
    optical_count_limit: delta registers are signed 8 bit: counts per read are clipped
        to [-limit-1, limit] and the excess is lost.
    optical_max_gap_m: the sensor sees the surface only within this distance (thesis: < 4 mm).
    accel_filter_hz: first-order low-pass on the acceleration estimate (0 = off).
    accel_noise_std_m_s2: white noise added to the acceleration estimate.
    accel_noise_snr_db: if set, noise on a_y at this SNR (thesis Fig. 23: 3 dB), relative to
        the running mean square of the clean estimate (causal "measured" power).
    grip_noise_snr_db: if set, white noise on the grip-force command at this SNR (Fig. 23a).
    """

    ft_rate_hz: float = 100.0
    ft_noise_std_n: float = 0.03
    ft_bias_std_n: float = 0.05
    ft_bias_n: float = 0.0
    optical_counts_per_m: float = 400.0 / 0.0254
    optical_frame_rate_hz: float = 1500.0
    optical_max_disp_per_frame_m: float = 0.0254 * 14.0 / 1500.0
    optical_report_rate_hz: float = 100.0
    optical_count_limit: int = 127
    optical_max_gap_m: float = 0.004
    accel_filter_hz: float = 0.0
    accel_noise_std_m_s2: float = 0.0
    accel_noise_snr_db: float | None = None
    grip_noise_snr_db: float | None = None

    def __post_init__(self) -> None:
        _finite(self)
        for n in ("ft_rate_hz", "optical_counts_per_m", "optical_frame_rate_hz",
                  "optical_max_disp_per_frame_m", "optical_report_rate_hz", "optical_max_gap_m"):
            _check(getattr(self, n) > 0, f"{n} must be > 0")
        for n in ("ft_noise_std_n", "ft_bias_std_n", "accel_filter_hz", "accel_noise_std_m_s2"):
            _check(getattr(self, n) >= 0, f"{n} must be >= 0")
        _check(self.optical_count_limit >= 1, "optical_count_limit must be >= 1")

    @property
    def optical_max_speed_m_s(self) -> float:
        """Speed above which the optical sensor loses track (m/s)."""
        return self.optical_frame_rate_hz * self.optical_max_disp_per_frame_m

    @property
    def optical_count_m(self) -> float:
        """Displacement of one count (m)."""
        return 1.0 / self.optical_counts_per_m


@dataclass(frozen=True)
class HandParams:
    """The receiver's hand: an impedance around a moving reference, and its grasp.

    mass_kg: effective hand/forearm mass (assumption 1 kg).
    stiffness_n_per_m, damping_n_s_per_m: arm endpoint impedance (human arm 200–800 N/m).
    grasp_stiffness_n_per_m, grasp_damping_n_s_per_m: hand–object coupling at full grasp.
    hold_grasp_level: grasp level above which a weight-supporting hand counts as holding.
    """

    mass_kg: float = 1.0
    stiffness_n_per_m: float = 400.0
    damping_n_s_per_m: float = 28.0
    grasp_stiffness_n_per_m: float = 1500.0
    grasp_damping_n_s_per_m: float = 20.0
    hold_grasp_level: float = 0.5

    def __post_init__(self) -> None:
        _finite(self)
        for f in fields(self):
            _check(getattr(self, f.name) > 0, f"HandParams.{f.name} must be > 0")


@dataclass(frozen=True)
class SimConfig:
    """One simulation setup shared by all episodes of a run.

    dt_s: plant step (s). duration_s: episode length (s).
    drop_distance_m: outcome rule, see `robot_sim.contact.outcome`.
    record_every: keep every k-th plant step in a trace.
    """

    obj: ObjectParams = field(default_factory=ObjectParams)
    gripper: GripperParams = field(default_factory=GripperParams)
    sensors: SensorParams = field(default_factory=SensorParams)
    hand: HandParams = field(default_factory=HandParams)
    dt_s: float = 0.001
    duration_s: float = 3.5
    drop_distance_m: float = 0.10
    record_every: int = 1

    def __post_init__(self) -> None:
        _check(math.isfinite(self.dt_s) and 1e-5 <= self.dt_s <= 0.01,
               f"dt_s must be in [1e-5, 0.01] s, got {self.dt_s}")
        _check(math.isfinite(self.duration_s) and self.duration_s > 0, "duration_s must be > 0")
        _check(self.drop_distance_m > 0, "drop_distance_m must be > 0")
        _check(self.record_every >= 1, "record_every must be >= 1")
        for rate, name in ((self.gripper.loop_rate_hz, "gripper.loop_rate_hz"),
                           (self.sensors.ft_rate_hz, "sensors.ft_rate_hz"),
                           (self.sensors.optical_report_rate_hz, "sensors.optical_report_rate_hz")):
            _check(rate * self.dt_s <= 1.0 + 1e-9, f"{name} = {rate} Hz is faster than the plant step 1/dt_s")

    @property
    def n_steps(self) -> int:
        """Plant steps per episode."""
        return int(round(self.duration_s / self.dt_s))

    def every(self, rate_hz: float) -> int:
        """Plant steps between two events of a periodic process at rate_hz."""
        return max(1, int(round(1.0 / (rate_hz * self.dt_s))))

    @property
    def control_period_s(self) -> float:
        """Period a release controller steps at with this setup (s): that of the faster of
        the wrist F/T sensor and the gripper's position loop (0.01 s by default: 100 Hz F/T,
        25 Hz loop; with a 250 Hz loop every loop tick latches a fresh command)."""
        return 1.0 / max(self.sensors.ft_rate_hz, self.gripper.loop_rate_hz)

    def with_gripper(self, force_rate_n_per_s: float, loop_rate_hz: float, max_force_n: float,
                     min_force_n: float = 0.0) -> "SimConfig":
        """This setup with another gripper: its rates (`with_gripper_rates`) and its force range,
        N (the maximum capped at the 140 N hand limit of ISO/TS 15066, which the plant keeps)."""
        out = self.with_gripper_rates(force_rate_n_per_s, loop_rate_hz)
        top = min(float(max_force_n), 140.0)
        return replace(out, gripper=replace(out.gripper, max_force_n=top, min_force_n=min(float(min_force_n), top / 2)))

    def with_gripper_rates(self, force_rate_n_per_s: float, loop_rate_hz: float) -> "SimConfig":
        """This setup with another gripper force rate (N/s) and position-loop rate (Hz). A
        loop faster than the wrist F/T sensor also reads the sensor at the loop's rate (a
        controller stepping faster than its force sensor would only repeat itself); the
        optical sensor keeps its read rate (its counts per read set its resolution). The loop
        period must be a whole number of plant steps, so the rate is what was asked."""
        steps = 1.0 / (loop_rate_hz * self.dt_s) if loop_rate_hz > 0 else math.nan
        _check(math.isfinite(steps) and steps >= 1.0 - 1e-9 and abs(steps - round(steps)) < 1e-9,
               f"loop_rate_hz = {loop_rate_hz} Hz is not a whole number of plant steps of {self.dt_s} s")
        gripper = self.gripper.with_rates(force_rate_n_per_s, loop_rate_hz)
        sensors = self.sensors
        if loop_rate_hz > sensors.ft_rate_hz:
            sensors = replace(sensors, ft_rate_hz=float(loop_rate_hz))
        return replace(self, gripper=gripper, sensors=sensors)
