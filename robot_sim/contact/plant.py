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

The same equations (`generic_step`) run n episodes on numpy arrays (batch) or one on Python
floats, chosen by the receiver parameters: floats → one episode, stacked arrays → a batch.
One episode steps with the same operations inline (`scalar_step`, fast per step, for the
real-time bridge and for plots) and skips the physics of steps that change nothing (`rest`);
both give the generic step's results bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from robot_sim.contact.actuator import GripperActuator
from robot_sim.contact.backend import NoiseSource, NumpyBackend, ScalarBackend
from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.generic_step import step_generic
from handover_model.grip import Mode, SensorSample
from robot_sim.contact.observation import Observation
from robot_sim.contact.receiver import Coupling, ReceiverParams, reference
from robot_sim.contact.rest import Rest, advance_scalar, reference_settled, shared_repeats
from robot_sim.contact.scalar_step import run_steps
from robot_sim.contact.sensors import OpticalMotionSensor, WristForceSensor
from robot_sim.contact.trace import TraceRecorder

__all__ = ["ContactPlant", "Observation", "TraceRecorder"]

_REF_CHUNK = 512  # reference samples precomputed at once for one episode (≈ 0.2 ms of work per block)
_REF_BLOCK = 128  # reference rows (time steps) precomputed at once for a batch
_GRASP, _SLIP, _RELEASE = int(Mode.GRASP), int(Mode.SLIP), int(Mode.RELEASE)


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
        self.ft_fresh = self.optical_fresh = True

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
        self._ref_cache: list[tuple] = []
        self._ref_base = 0
        self._ref_settled: tuple[int, tuple] | None = None  # (from step, the sample): constant from then on
        self._rest: Rest | None = None  # a fixed point of the scalar step (robot_sim.contact.rest)
        #: Whether the plant may sleep once still (`robot_sim.contact.rest`; off: every step
        #: that changes something is computed), and the calls in a row that ended still.
        self.may_sleep = False
        self.still_ticks = 0

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
        self._rest, self.still_ticks = None, 0

    # ------------------------------------------------------------------ helpers
    @property
    def rest(self) -> Rest | None:
        """The fixed point the plant replays now (proven, or a sleep), or None: while the same
        one stays, its physics state does not change (`robot_sim.contact.rest`)."""
        return self._rest

    @property
    def time_s(self) -> float:
        """Episode time (s) of the current state."""
        return self.step_index * self.dt_s

    def _reference_at(self, k: int):
        """Receiver reference at step k, computed ahead in blocks (vectorised over time)."""
        i = k - self._ref_base
        if i < 0 or i >= len(self._ref_cache):
            if self._ref_settled is not None and k >= self._ref_settled[0]:
                return self._ref_settled[1]
            follows = self._ref_cache[-1:] if i == len(self._ref_cache) else []
            self._ref_base = k
            i = 0
            if self.vectorised:
                t = ((k + np.arange(_REF_BLOCK)) * self.dt_s)[:, None]
                cols = [np.ascontiguousarray(c) for c in np.broadcast_arrays(*reference(t, self.receiver))]
                self._ref_cache = [tuple(c[j] for c in cols) for j in range(_REF_BLOCK)]
            else:
                t = (k + np.arange(_REF_CHUNK)) * self.dt_s
                self._ref_cache = shared_repeats(np.broadcast_arrays(*reference(t, self.receiver)), follows)
                if reference_settled(self.receiver, t[-1]):
                    self._ref_settled = (k + _REF_CHUNK, self._ref_cache[-1])
        return self._ref_cache[i]

    # ------------------------------------------------------------------ stepping
    def step(self, grip_command_n) -> None:
        """Advance one plant step of `dt_s` with the given grip-force command (N)."""
        self._rest = None
        if not self.vectorised and type(grip_command_n) is float:
            run_steps(self, grip_command_n, 1)
        else:
            step_generic(self, grip_command_n)

    def _latch(self, grip_command_n) -> None:
        """The gripper's position loop takes the command (N), with its noise if configured."""
        cmd = grip_command_n
        if self._grip_snr is not None:
            self._grip_ms_sum = self._grip_ms_sum + cmd * cmd
            self._grip_ms_n += 1
            std = self.xp.sqrt(self._grip_ms_sum / (self._grip_ms_n * self._grip_snr))
            cmd = self.xp.maximum(cmd + std * self._noise.normal(), 0.0)
        self.actuator.latch(cmd)

    def advance_real_time(self, elapsed_s: float, grip_command_n) -> Observation:
        """Real-time use at an irregular rate: run the whole plant steps that `elapsed_s` (s,
        since the last call) completes, carrying the fraction of a step to the next call, so
        the plant's time never runs ahead of the caller's (a short extra tick runs no step
        and returns the current observation)."""
        self.run_real_time(elapsed_s, grip_command_n)
        return self.observation()

    def run_real_time(self, elapsed_s: float, grip_command_n) -> None:
        """`advance_real_time` without building the observation (read the plant's state)."""
        if not math.isfinite(elapsed_s) or elapsed_s < 0:
            raise ContactSimError(f"elapsed_s must be finite and >= 0, got {elapsed_s}")
        self._carry_s += elapsed_s
        steps = int(math.floor(self._carry_s / self.dt_s + 1e-9))
        if steps >= 1:
            self._carry_s = max(0.0, self._carry_s - steps * self.dt_s)
            self.run(steps * self.dt_s, grip_command_n)

    def advance(self, duration_s: float, grip_command_n) -> Observation:
        """Run whole plant steps covering `duration_s` (at least one) with a constant command,
        and return the observation at the end (real-time use: call at your own rate)."""
        self.run(duration_s, grip_command_n)
        return self.observation()

    def run(self, duration_s: float, grip_command_n) -> None:
        """`advance` without building the observation. A one-episode plant skips the physics
        of steps that would change nothing (`robot_sim.contact.rest`; same results)."""
        if not math.isfinite(duration_s) or duration_s < 0:
            raise ContactSimError(f"duration_s must be finite and >= 0, got {duration_s}")
        if self.vectorised or type(grip_command_n) is not float:
            cmd = np.asarray(grip_command_n, dtype=float)
            if not np.all(np.isfinite(cmd)) or np.any(cmd < 0):
                raise ContactSimError(f"grip_command_n must be finite and >= 0, got {grip_command_n}")
            if not self.vectorised:
                grip_command_n = float(cmd)
        elif not math.isfinite(grip_command_n) or grip_command_n < 0:
            raise ContactSimError(f"grip_command_n must be finite and >= 0, got {grip_command_n}")
        self.ft_fresh = self.optical_fresh = False
        n = max(1, int(round(duration_s / self.dt_s)))
        if not self.vectorised:
            advance_scalar(self, grip_command_n, n)
            return
        for _ in range(n):
            step_generic(self, grip_command_n)

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
