"""Sensor models: wrist force/torque sensor and an ADNS-2051-class optical motion sensor.

Wrist F/T (thesis §3.6: ATI Gamma sampled at 100 Hz): reads the load the object puts on
the gripper (the negative of the pads' friction force on the object), gripper frame
(x toward the receiver, y down), plus a per-episode bias and white noise; a sample is
taken every 1/ft_rate_hz and held until the next one.

Optical sensor (mouse sensor on a finger pad, e.g. ADNS-2051): it accumulates the object's
displacement relative to the pad only while the object surface is over it (object face
within reach, pad gap ≤ 4 mm, object still between the pads) and only while the speed is
trackable (frame rate × largest displacement per frame; faster motion is lost). The host
reads the delta registers every 1/optical_report_rate_hz: the displacement is quantised
to whole counts (the sub-count remainder stays in the sensor), clipped to the signed 8-bit
register range (the excess is lost), and turned into a velocity estimate
v = counts / (counts_per_m · T) and an acceleration estimate a_y = Δv_y / T (optionally
low-pass filtered). Noise is added to a_y: white with a fixed σ, and/or at a given SNR
relative to the running mean square of the clean estimate (thesis Fig. 23: SNR = 3 dB).
While the surface is lost the estimates read 0 and the `valid` flag is False.
"""

from __future__ import annotations

import math

from robot_sim.contact.backend import NoiseSource
from robot_sim.contact.config import SensorParams

__all__ = ["WristForceSensor", "OpticalMotionSensor"]


class WristForceSensor:
    """100 Hz wrist F/T model (x, y forces) for n episodes."""

    def __init__(self, params: SensorParams, xp, n: int, noise: NoiseSource):
        self.params = params
        self._noise = noise
        self.bias_x_n = params.ft_bias_n + params.ft_bias_std_n * noise.normal()
        self.bias_y_n = params.ft_bias_n + params.ft_bias_std_n * noise.normal()
        self.force_x_n = xp.full(n, 0.0) + self.bias_x_n
        self.force_y_n = xp.full(n, 0.0) + self.bias_y_n

    def sample(self, true_x_n, true_y_n) -> None:
        """Take one sample of the true load (N)."""
        s = self.params.ft_noise_std_n
        if s > 0.0:
            self.force_x_n = true_x_n + self.bias_x_n + s * self._noise.normal()
            self.force_y_n = true_y_n + self.bias_y_n + s * self._noise.normal()
        else:
            self.force_x_n = true_x_n + self.bias_x_n
            self.force_y_n = true_y_n + self.bias_y_n


class OpticalMotionSensor:
    """Mouse-type displacement sensor with velocity and acceleration estimates, n episodes."""

    def __init__(self, params: SensorParams, xp, n: int, noise: NoiseSource):
        self.params = params
        self.xp = xp
        self._noise = noise
        self._cpm = params.optical_counts_per_m
        self._count_m = 1.0 / params.optical_counts_per_m
        self._period_s = 1.0 / params.optical_report_rate_hz
        self._max_speed = params.optical_max_speed_m_s
        self._lo = -float(params.optical_count_limit) - 1.0
        self._hi = float(params.optical_count_limit)
        fc = params.accel_filter_hz
        self._alpha = 1.0 if fc <= 0 else 1.0 - math.exp(-2.0 * math.pi * fc * self._period_s)
        self._snr_ratio = None if params.accel_noise_snr_db is None else 10.0 ** (params.accel_noise_snr_db / 10.0)
        zero = xp.full(n, 0.0)
        self._acc_x = zero
        self._acc_y = zero
        self.counts_x = zero
        self.counts_y = zero
        self.velocity_x_m_s = zero
        self.velocity_y_m_s = zero
        self.accel_y_m_s2 = zero
        self._filtered = zero
        self.valid = xp.full(n, True)
        self._ms_sum = zero
        self._ms_n = 0

    def accumulate(self, dx_m, dy_m, speed_m_s, surface_visible) -> None:
        """Add one plant step of true relative displacement (m) if the sensor can track it."""
        xp = self.xp
        ok = surface_visible & (speed_m_s <= self._max_speed)
        self._acc_x = self._acc_x + xp.where(ok, dx_m, 0.0)
        self._acc_y = self._acc_y + xp.where(ok, dy_m, 0.0)

    def report(self, surface_visible) -> None:
        """Host reads the delta registers and updates the estimates."""
        xp = self.xp
        cx = xp.trunc(self._acc_x * self._cpm)
        cy = xp.trunc(self._acc_y * self._cpm)
        self._acc_x = self._acc_x - cx * self._count_m
        self._acc_y = self._acc_y - cy * self._count_m
        cx = xp.clip(cx, self._lo, self._hi)
        cy = xp.clip(cy, self._lo, self._hi)
        self.counts_x = xp.where(surface_visible, cx, 0.0)
        self.counts_y = xp.where(surface_visible, cy, 0.0)
        scale = self._count_m / self._period_s
        vx = self.counts_x * scale
        vy = self.counts_y * scale
        a_raw = xp.where(surface_visible & self.valid, (vy - self.velocity_y_m_s) / self._period_s, 0.0)
        filt = xp.where(surface_visible, self._filtered + self._alpha * (a_raw - self._filtered), 0.0)
        self._filtered = filt
        noise_std = self.params.accel_noise_std_m_s2
        if self._snr_ratio is not None:
            self._ms_sum = self._ms_sum + filt * filt
            self._ms_n += 1
            noise_std = xp.sqrt(noise_std * noise_std + self._ms_sum / (self._ms_n * self._snr_ratio))
            a = filt + noise_std * self._noise.normal()
        elif noise_std > 0.0:
            a = filt + noise_std * self._noise.normal()
        else:
            a = filt
        self.accel_y_m_s2 = xp.where(surface_visible, a, 0.0)
        self.velocity_x_m_s = vx
        self.velocity_y_m_s = vy
        self.valid = surface_visible
