"""The contact plant: an object between two friction pads, gravity, the receiver's hand.

Model (2-D, the gripper frame of the transfer loop: x toward the receiver, y DOWN). The
thesis's Fig. 15 puts the pull F_p in the plane perpendicular to the grip force, so every
force that matters (weight, pull, friction) lies in that plane and the grip force only
sets the friction limit: a 2-D model in that plane loses nothing the controllers can
see. The gripper is held still during the transfer (the arm is not part of this plant).

Per plant step dt (semi-implicit Euler, one friction solve per step):
1. The receiver's hand (mass on an impedance around its reference, see `receiver`) acts on
   the object through its grasp: spring–damper scaled by the grasp level, capped by the
   grasp strength; or only along the pull (dropping); or a one-sided contact (bumping).
2. External force on the object: F_ext = F_hand + (0, M g).
3. Coulomb friction of the pads with total normal force F_G (μ_s, μ_k are for both pads):
   - sticking: stays stuck while |F_ext| ≤ μ_s F_G (the pads take exactly −F_ext);
   - otherwise slides: the kinetic friction impulse dt μ_k F_G opposes the trial momentum
     p* = M v + dt F_ext (implicit direction, so a slide that reverses within a step is
     handled); if |p*| ≤ dt μ_k F_G the slip velocity reaches zero within the step: the
     object stops, and sticks again only if |F_ext| ≤ μ_s F_G (re-stick at zero slip
     velocity inside the static cone), otherwise it keeps slipping from rest.
4. The object leaves the pads for good once it has slid beyond the pad extent along x or y
   (|x| > pad_extent_x_m or |y| > pad_extent_y_m); from then on the pads exert nothing
   and it falls freely unless the receiver's hand holds it. No table or floor is
   modelled below the gripper: an unheld object keeps falling.
5. The wrist sensor's true load is minus the pads' friction force; the mode is GRASP
   (stuck), SLIP (pads press, object slides) or RELEASE (pads exert no force).

The same code runs one episode on Python floats (fast per step, for the real-time bridge
and for plots) or n episodes on numpy arrays (batch), chosen by the receiver parameters:
floats → one episode, stacked arrays → a batch.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from robot_sim.contact.actuator import GripperActuator
from robot_sim.contact.backend import NoiseSource, NumpyBackend, ScalarBackend
from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.interfaces import Mode, SensorSample
from robot_sim.contact.outcome import EpisodeTrace
from robot_sim.contact.receiver import Coupling, ReceiverParams, reference
from robot_sim.contact.sensors import OpticalMotionSensor, WristForceSensor

__all__ = ["ContactPlant", "Observation", "TraceRecorder"]

_TINY = 1e-12
_REF_CHUNK = 4096  # reference samples precomputed at once for one episode
_REF_BLOCK = 128  # reference rows (time steps) precomputed at once for a batch
_GRASP, _SLIP, _RELEASE = int(Mode.GRASP), int(Mode.SLIP), int(Mode.RELEASE)


@dataclass(frozen=True)
class Observation:
    """Everything one plant step produces, for one episode (floats) or a batch (arrays).

    Sensors (what a real robot would have), gripper frame x toward receiver, y down:
        time_s; wrist_force_x_n, wrist_force_y_n (F/T, with noise and bias; held between
        samples); ft_fresh (a new F/T sample was taken in the last advance);
        optical_counts_x, optical_counts_y (last register read, counts);
        optical_counts_per_m; optical_dt_s (report period); optical_valid;
        slip_velocity_x_m_s, slip_velocity_y_m_s, accel_y_m_s2 (estimates);
        optical_fresh; gripper_finger_m (finger position − contact position x0, m);
        grip_force_estimate_n (spring force from the finger position, N).
    Ground truth (never for control):
        mode (Mode value); grip_force_n (force the pads really apply); object_position_x_m,
        object_position_y_m (displacement from the start, m); object_velocity_x_m_s,
        object_velocity_y_m_s; object_accel_x_m_s2, object_accel_y_m_s2; hand_position_x_m,
        hand_position_y_m (receiver hand, same frame); pull_force_x_n, pull_force_y_n
        (receiver's force on the object); true_wrist_force_x_n, true_wrist_force_y_n;
        receiver_grasp (0..1); receiver_holds; left_pads; dropped.
    """

    time_s: float
    wrist_force_x_n: object
    wrist_force_y_n: object
    ft_fresh: bool
    optical_counts_x: object
    optical_counts_y: object
    optical_counts_per_m: float
    optical_dt_s: float
    optical_valid: object
    slip_velocity_x_m_s: object
    slip_velocity_y_m_s: object
    accel_y_m_s2: object
    optical_fresh: bool
    gripper_finger_m: object
    grip_force_estimate_n: object
    mode: object
    grip_force_n: object
    object_position_x_m: object
    object_position_y_m: object
    object_velocity_x_m_s: object
    object_velocity_y_m_s: object
    object_accel_x_m_s2: object
    object_accel_y_m_s2: object
    hand_position_x_m: object
    hand_position_y_m: object
    pull_force_x_n: object
    pull_force_y_n: object
    true_wrist_force_x_n: object
    true_wrist_force_y_n: object
    receiver_grasp: object
    receiver_holds: object
    left_pads: object
    dropped: object


class ContactPlant:
    """Object, pads, gripper actuator, receiver hand and sensors for 1 or n episodes.

    Args:
        config: shared simulation setup.
        receiver: one behaviour (floats → one episode on Python floats) or a stacked batch
            (arrays of shape (n,) → n episodes on numpy arrays).
        seed: seed of this plant's noise (F/T bias and noise, optical noise, grip noise).
            Same seed, same receiver, same commands → the same run, bit for bit.
        initial_grip_force_n: grip force at t = 0 (the object starts at rest between the
            pads; the actuator starts settled at this force).

    Use `step(grip_command_n)` for one plant step of `config.dt_s`, or
    `advance(duration_s, grip_command_n)` for real-time use (whole plant steps).
    """

    def __init__(self, config: SimConfig, receiver: ReceiverParams, seed: int | np.random.SeedSequence = 0,
                 initial_grip_force_n=10.0):
        self.config = config
        self.receiver = receiver
        vectorised = np.ndim(receiver.pull_angle_rad) > 0
        self.n = receiver.n_episodes if vectorised else 1
        xp = NumpyBackend if vectorised else ScalarBackend
        self.xp = xp
        self.vectorised = vectorised
        self.rng = np.random.default_rng(seed)
        noise = NoiseSource(self.rng, self.n, vectorised)
        self._noise = noise
        c, o = config, config.obj
        self.dt_s = c.dt_s
        self._carry_s = 0.0  # advance_real_time: the fraction of a plant step not yet run, s
        self.step_index = 0
        init = np.asarray(initial_grip_force_n, dtype=float)
        if not np.all(np.isfinite(init)):
            raise ContactSimError("initial_grip_force_n must be finite")
        init_v = init if vectorised else float(init)
        self.actuator = GripperActuator(c.gripper, c.dt_s, xp, self.n, init_v)
        self.ft = WristForceSensor(c.sensors, xp, self.n, noise)
        self.optical = OpticalMotionSensor(c.sensors, xp, self.n, noise)
        self._gripper_every = c.every(c.gripper.loop_rate_hz)
        self._ft_every = c.every(c.sensors.ft_rate_hz)
        self._opt_every = c.every(c.sensors.optical_report_rate_hz)
        self._grip_snr = None if c.sensors.grip_noise_snr_db is None else 10.0 ** (c.sensors.grip_noise_snr_db / 10.0)
        self._grip_ms_sum = xp.full(self.n, 0.0)
        self._grip_ms_n = 0
        self._set_receiver_constants(receiver)
        hand = c.hand
        self._constants = (c.dt_s, o.mass_kg, o.weight_n, o.mu_static, o.mu_kinetic,
                           hand.grasp_stiffness_n_per_m, hand.grasp_damping_n_s_per_m,
                           hand.stiffness_n_per_m, hand.damping_n_s_per_m, hand.mass_kg,
                           o.pad_extent_x_m, o.pad_extent_y_m, o.optical_face_x_m, o.optical_face_y_m,
                           c.sensors.optical_max_gap_m, c.drop_distance_m, hand.hold_grasp_level,
                           c.gripper.spring_n_per_m)
        # State.
        z = xp.full(self.n, 0.0)
        self.px, self.py, self.vx, self.vy = z, z, z, z
        self.ax, self.ay = z, z
        r0 = reference(0.0, receiver)
        self.hx = xp.asarray(r0[0]) if vectorised else float(r0[0])
        self.hy = xp.asarray(r0[1]) if vectorised else float(r0[1])
        self.hvx, self.hvy = z, z
        fg0 = self.actuator.spring_force_n()
        w = o.weight_n
        self.stuck = (xp.full(self.n, True) & (w <= o.mu_static * fg0 + 0.0) if vectorised
                      else bool(w <= o.mu_static * fg0))
        self.left = xp.full(self.n, False)
        self.dropped = xp.full(self.n, False)
        self.mode = xp.where(fg0 > 0.0, xp.where(self.stuck, _GRASP, _SLIP), _RELEASE)
        self.grip_force_n = xp.where(fg0 > 0.0, fg0, 0.0)
        self.pull_x, self.pull_y = z, z
        self.wrist_x = z
        self.wrist_y = xp.where(self.stuck, w, o.mu_kinetic * fg0) + z
        self.grasp, self.holds = z, xp.full(self.n, False)
        self.ft.sample(self.wrist_x, self.wrist_y)
        self.ft_fresh = True
        self.optical_fresh = True

    def _set_receiver_constants(self, p: ReceiverParams) -> None:
        self.receiver = p
        if self.vectorised:
            self._ux, self._uy = np.cos(p.pull_angle_rad), np.sin(p.pull_angle_rad)
            self._c_full = p.coupling == Coupling.FULL
            self._c_along = p.coupling == Coupling.ALONG_PULL
            self._c_contact = p.coupling == Coupling.CONTACT
            self._strength = np.asarray(p.grasp_strength_n, dtype=float)
        else:
            self._ux, self._uy = float(np.cos(p.pull_angle_rad)), float(np.sin(p.pull_angle_rad))
            self._c_full = int(p.coupling) == Coupling.FULL
            self._c_along = int(p.coupling) == Coupling.ALONG_PULL
            self._c_contact = int(p.coupling) == Coupling.CONTACT
            self._strength = float(p.grasp_strength_n)
        self._ref_cache = []
        self._ref_base = 0

    def replace_receiver(self, receiver: ReceiverParams) -> None:
        """Swap the receiver behaviour mid-run (one episode only), e.g. when the receiver's
        hand arrives at the object during a full handover. The new behaviour's times are on
        this plant's clock (`time_s`); the hand is placed at the new reference at the current
        time, at rest. The object, pads, actuator and sensors keep their state."""
        if self.vectorised or receiver.n_episodes != 1:
            raise ContactSimError("replace_receiver works on a single-episode plant with one behaviour")
        self._set_receiver_constants(receiver)
        r = reference(self.time_s, receiver)
        self.hx, self.hy = float(r[0]), float(r[1])
        self.hvx, self.hvy = 0.0, 0.0

    # ------------------------------------------------------------------ helpers
    @property
    def time_s(self) -> float:
        """Episode time (s) of the current state."""
        return self.step_index * self.dt_s

    def _reference_at(self, k: int):
        """Receiver reference at step k, computed ahead in blocks (vectorised over time)."""
        i = k - self._ref_base
        if i < 0 or i >= len(self._ref_cache):
            self._ref_base = k
            i = 0
            if self.vectorised:
                t = ((k + np.arange(_REF_BLOCK)) * self.dt_s)[:, None]
                cols = [np.ascontiguousarray(c) for c in np.broadcast_arrays(*reference(t, self.receiver))]
                self._ref_cache = [tuple(c[j] for c in cols) for j in range(_REF_BLOCK)]
            else:
                t = (k + np.arange(_REF_CHUNK)) * self.dt_s
                cols = np.broadcast_arrays(*reference(t, self.receiver))
                self._ref_cache = list(zip(*[c.tolist() for c in cols]))
        return self._ref_cache[i]

    # ------------------------------------------------------------------ stepping
    def step(self, grip_command_n) -> None:
        """Advance one plant step of `dt_s` with the given grip-force command (N)."""
        xp = self.xp
        where, maximum, hypot = xp.where, xp.maximum, xp.hypot
        (dt, m, w, mu_s, mu_k, kc, cc, kh, dh, mh, ext_x, ext_y, face_x, face_y,
         max_gap, drop_m, hold_level, k_spring) = self._constants
        k = self.step_index
        act = self.actuator

        if k % self._gripper_every == 0:
            cmd = grip_command_n
            if self._grip_snr is not None:
                self._grip_ms_sum = self._grip_ms_sum + cmd * cmd
                self._grip_ms_n += 1
                std = xp.sqrt(self._grip_ms_sum / (self._grip_ms_n * self._grip_snr))
                cmd = maximum(cmd + std * self._noise.normal(), 0.0)
            act.latch(cmd)

        rx, ry, rvx, rvy, g, ffy = self._reference_at(k)
        px, py, vx, vy = self.px, self.py, self.vx, self.vy
        hx, hy, hvx, hvy = self.hx, self.hy, self.hvx, self.hvy

        # 1. Hand on object.
        dx, dy = hx - px, hy - py
        dvx, dvy = hvx - vx, hvy - vy
        fx = g * (kc * dx + cc * dvx)
        fy = g * (kc * dy + cc * dvy)
        ux, uy = self._ux, self._uy
        c_full, c_along = self._c_full, self._c_along
        along = fx * ux + fy * uy
        pen = dx * ux + dy * uy
        push = where(pen > 0.0, maximum(kc * pen + cc * (dvx * ux + dvy * uy), 0.0), 0.0)
        fx = where(c_full, fx, where(c_along, along * ux, push * ux))
        fy = where(c_full, fy, where(c_along, along * uy, push * uy))
        cap = where(self._c_contact, self._strength, g * self._strength)
        mag = hypot(fx, fy)
        sc = where(mag > cap, cap / maximum(mag, _TINY), 1.0)
        fx, fy = fx * sc, fy * sc

        # 2.-3. Pads: Coulomb friction with stick/slip.
        finger = act.finger_m
        fg_spring = k_spring * maximum(finger, 0.0)
        left = self.left
        in_pads = xp.not_(left) & (fg_spring > 0.0)
        fg = where(in_pads, fg_spring, 0.0)
        ex, ey = fx, fy + w
        ptx, pty = m * vx + dt * ex, m * vy + dt * ey
        pt = hypot(ptx, pty)
        jk = dt * mu_k * fg
        can_hold = in_pads & (hypot(ex, ey) <= mu_s * fg)
        stay = self.stuck & can_hold
        stops = pt <= jk
        stuck = stay | (stops & can_hold)
        keep = where(stay | stops, 0.0, 1.0 - jk / maximum(pt, _TINY))
        nvx, nvy = ptx * keep / m, pty * keep / m
        self.wrist_x = (ptx - m * nvx) / dt
        self.wrist_y = (pty - m * nvy) / dt
        self.ax, self.ay = (nvx - vx) / dt, (nvy - vy) / dt
        npx, npy = px + dt * nvx, py + dt * nvy
        self.mode = where(in_pads, where(stuck, _GRASP, _SLIP), _RELEASE)
        self.grip_force_n = fg
        self.stuck = stuck
        abs_ = xp.abs
        apx, apy = abs_(npx), abs_(npy)
        left = left | (apx > ext_x) | (apy > ext_y)
        self.left = left

        # Hand impedance (reaction of the object on the hand included).
        hvx = hvx + dt * (kh * (rx - hx) + dh * (rvx - hvx) - fx) / mh
        hvy = hvy + dt * (kh * (ry - hy) + dh * (rvy - hvy) + ffy - fy) / mh
        self.hx, self.hy = hx + dt * hvx, hy + dt * hvy
        self.hvx, self.hvy = hvx, hvy

        self.pull_x, self.pull_y = fx, fy
        self.grasp = g
        holds = c_full & (g >= hold_level) & (hypot(dx, dy) < 0.02)
        self.holds = holds
        self.dropped = self.dropped | ((npy > drop_m) & xp.not_(holds))

        # Sensors.
        visible = xp.not_(left) & (apx <= face_x) & (apy <= face_y) & (maximum(-finger, 0.0) <= max_gap)
        self.optical.accumulate(npx - px, npy - py, hypot(nvx, nvy), visible)
        self.px, self.py, self.vx, self.vy = npx, npy, nvx, nvy
        act.move()
        k += 1
        self.step_index = k
        if k % self._ft_every == 0:
            self.ft.sample(self.wrist_x, self.wrist_y)
            self.ft_fresh = True
        if k % self._opt_every == 0:
            self.optical.report(visible)
            self.optical_fresh = True

    def advance_real_time(self, elapsed_s: float, grip_command_n) -> Observation:
        """Real-time use at an irregular rate: run the whole plant steps that `elapsed_s` (s,
        since the last call) completes, carrying the fraction of a step to the next call, so
        the plant's time never runs ahead of the caller's (a short extra tick runs no step
        and returns the current observation)."""
        if not np.isfinite(elapsed_s) or elapsed_s < 0:
            raise ContactSimError(f"elapsed_s must be finite and >= 0, got {elapsed_s}")
        self._carry_s += elapsed_s
        steps = int(math.floor(self._carry_s / self.dt_s + 1e-9))
        if steps < 1:
            return self.observation()
        self._carry_s = max(0.0, self._carry_s - steps * self.dt_s)
        return self.advance(steps * self.dt_s, grip_command_n)

    def advance(self, duration_s: float, grip_command_n) -> Observation:
        """Run whole plant steps covering `duration_s` (at least one) with a constant command,
        and return the observation at the end (real-time use: call at your own rate)."""
        if not np.isfinite(duration_s) or duration_s < 0:
            raise ContactSimError(f"duration_s must be finite and >= 0, got {duration_s}")
        cmd = np.asarray(grip_command_n, dtype=float)
        if not np.all(np.isfinite(cmd)) or np.any(cmd < 0):
            raise ContactSimError(f"grip_command_n must be finite and >= 0, got {grip_command_n}")
        if not self.vectorised:
            grip_command_n = float(cmd)
        self.ft_fresh = False
        self.optical_fresh = False
        for _ in range(max(1, int(round(duration_s / self.dt_s)))):
            self.step(grip_command_n)
        return self.observation()

    # ------------------------------------------------------------------ outputs
    def sensor_sample(self) -> SensorSample:
        """The controller's view now (arrays of shape (n,), also for one episode)."""
        opt = self.optical
        if self.vectorised:
            def a(v, dtype=float):
                return np.array(v, dtype=dtype, copy=True)
        else:
            def a(v, dtype=float):
                return np.array((v,), dtype=dtype)
        return SensorSample(
            time_s=self.time_s,
            force_x_n=a(self.ft.force_x_n),
            force_y_n=a(self.ft.force_y_n),
            accel_y_m_s2=a(opt.accel_y_m_s2),
            slip_velocity_x_m_s=a(opt.velocity_x_m_s),
            slip_velocity_y_m_s=a(opt.velocity_y_m_s),
            optical_valid=a(opt.valid, bool),
            grip_force_n=a(self.actuator.spring_force_n()),
            force_fresh=self.ft_fresh,
            optical_fresh=self.optical_fresh,
        )

    def observation(self) -> Observation:
        """Sensors and ground truth now (floats for one episode, arrays for a batch)."""
        opt = self.optical
        return Observation(
            time_s=self.time_s,
            wrist_force_x_n=self.ft.force_x_n, wrist_force_y_n=self.ft.force_y_n, ft_fresh=self.ft_fresh,
            optical_counts_x=opt.counts_x, optical_counts_y=opt.counts_y,
            optical_counts_per_m=self.config.sensors.optical_counts_per_m,
            optical_dt_s=self._opt_every * self.dt_s, optical_valid=opt.valid,
            slip_velocity_x_m_s=opt.velocity_x_m_s, slip_velocity_y_m_s=opt.velocity_y_m_s,
            accel_y_m_s2=opt.accel_y_m_s2, optical_fresh=self.optical_fresh,
            gripper_finger_m=self.actuator.finger_m, grip_force_estimate_n=self.actuator.spring_force_n(),
            mode=self.mode, grip_force_n=self.grip_force_n,
            object_position_x_m=self.px, object_position_y_m=self.py,
            object_velocity_x_m_s=self.vx, object_velocity_y_m_s=self.vy,
            object_accel_x_m_s2=self.ax, object_accel_y_m_s2=self.ay,
            hand_position_x_m=self.hx, hand_position_y_m=self.hy,
            pull_force_x_n=self.pull_x, pull_force_y_n=self.pull_y,
            true_wrist_force_x_n=self.wrist_x, true_wrist_force_y_n=self.wrist_y,
            receiver_grasp=self.grasp, receiver_holds=self.holds, left_pads=self.left, dropped=self.dropped,
        )


class TraceRecorder:
    """Collects one scalar episode's samples into an `EpisodeTrace`."""

    _FIELDS = ("time_s", "mode", "grip_force_n", "pull_force_x_n", "pull_force_y_n",
               "object_position_x_m", "object_position_y_m", "object_accel_y_m_s2", "receiver_holds",
               "grip_command_n", "object_velocity_x_m_s", "object_velocity_y_m_s", "object_accel_x_m_s2",
               "sensed_force_x_n", "sensed_force_y_n", "accel_estimate_y_m_s2", "optical_valid",
               "hand_position_x_m", "hand_position_y_m", "receiver_grasp")

    def __init__(self):
        self._rows: list[tuple] = []

    def record(self, plant: ContactPlant, grip_command_n: float) -> None:
        """Append the plant's current state (one episode only)."""
        p = plant
        self._rows.append((p.time_s, p.mode, p.grip_force_n, p.pull_x, p.pull_y, p.px, p.py, p.ay, p.holds,
                           grip_command_n, p.vx, p.vy, p.ax, p.ft.force_x_n, p.ft.force_y_n,
                           p.optical.accel_y_m_s2, p.optical.valid, p.hx, p.hy, p.grasp))

    def trace(self, label: str = "") -> EpisodeTrace:
        """The recorded samples as an `EpisodeTrace`."""
        cols = list(zip(*self._rows)) if self._rows else [()] * len(self._FIELDS)
        arrays = {}
        for name, col in zip(self._FIELDS, cols):
            if name == "mode":
                arrays[name] = np.asarray(col, dtype=np.int8)
            elif name in ("receiver_holds", "optical_valid"):
                arrays[name] = np.asarray(col, dtype=bool)
            else:
                arrays[name] = np.asarray(col, dtype=float)
        return EpisodeTrace(**arrays, label=label)
