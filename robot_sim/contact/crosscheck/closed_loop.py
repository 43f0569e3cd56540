"""A release controller closed-loop on MuJoCo: one episode of our benchmark (object, friction,
receiver, gripper class, sensor noise) with the contact physics of `MujocoPinch` instead of
our plant's, judged by the rules of `robot_sim.contact.outcome`.

What is shared with our plant (`robot_sim.contact.episode.run_episode`), so that only the
contact physics differs:
- the controller, stepped every `SimConfig.control_period_s` (10 ms, or the loop's period
  above 100 Hz) with a `SensorSample`, its command passed through our gripper actuator
  (`GripperActuator`: the loop's latch, lag, force rate and range) whose spring force drives
  MuJoCo's pad motors;
- the receiver: its law (`runs.receiver_forces`: impedance around r(t), grasp coupling,
  feedforward, force cap) evaluated each step on MuJoCo's state;
- the sensors: our models (`robot_sim.contact.sensors`: F/T bias, noise and sample-and-hold;
  the optical sensor's surface check, speed limit, quantisation to counts, 8-bit clip,
  velocity and a_y estimates with their noise), fed from MuJoCo's state. The wrist F/T reads
  the load the box puts on the pads (`MujocoPinch.pad_load_n`: MuJoCo's constraint forces);
  the optical sensor accumulates the box's motion relative to the (fixed) pads;
- the noise: one seeded `NoiseSource` drawn in the same order as our plant's, so the same
  seed gives both plants the same bias and noise draws.

Ground truth from MuJoCo, in our plant's terms: RELEASE when the pads press no more
(`MujocoPinch.pad_press_n` is 0, or the box has left the pads' footprint), otherwise SLIP when
the box moves faster than 1 mm/s relative to the pads (`measure.SLIP_SPEED_M_S`: MuJoCo's
soft friction lets a stuck box creep) and GRASP when not. The outcome (dropped, handed over,
force overshoot, release time, slip distance) is `outcome_from_trace` of the recorded trace.

Frames and units: our gripper frame (x toward the receiver, y DOWN); m, m/s, N, s.
"""

from __future__ import annotations

import math

import numpy as np

from handover_model.grip import GripController, Mode, SensorSample
from robot_sim.contact.actuator import GripperActuator
from robot_sim.contact.backend import NoiseSource, ScalarBackend
from robot_sim.contact.config import ContactSimError, SimConfig
from robot_sim.contact.crosscheck.measure import SLIP_SPEED_M_S
from robot_sim.contact.crosscheck.mjcf import MujocoParams, MujocoPinch
from robot_sim.contact.crosscheck.runs import receiver_forces
from robot_sim.contact.episode import EpisodeResult, rest_sample
from robot_sim.contact.outcome import EpisodeTrace, outcome_from_trace
from robot_sim.contact.receiver import ReceiverParams, reference
from robot_sim.contact.sensors import OpticalMotionSensor, WristForceSensor

__all__ = ["MujocoSensors", "run_mujoco_episode", "holds_at_release"]

_GRASP, _SLIP, _RELEASE = int(Mode.GRASP), int(Mode.SLIP), int(Mode.RELEASE)
_FIELDS = ("time_s", "mode", "grip_force_n", "pull_force_x_n", "pull_force_y_n", "object_position_x_m",
           "object_position_y_m", "object_accel_y_m_s2", "receiver_holds", "grip_command_n",
           "object_velocity_x_m_s", "object_velocity_y_m_s", "sensed_force_x_n", "sensed_force_y_n",
           "optical_valid")


class MujocoSensors:
    """Our wrist F/T and optical sensor models (`robot_sim.contact.sensors`), fed from MuJoCo.

    Draws its noise from `NoiseSource(default_rng(seed))` in our plant's order: two F/T biases,
    the first F/T sample, then per plant step the F/T sample and the optical report when due.

    Args:
        config: the episode's setup (sensor parameters and rates, object face, plant step).
        seed: the noise seed (the same as our plant's for the same draws).
        initial_load_n: the load at t = 0 (x, y down; N): the settled object's.
    """

    def __init__(self, config: SimConfig, seed: int | np.random.SeedSequence,
                 initial_load_n: tuple[float, float]) -> None:
        if config.sensors.grip_noise_snr_db is not None:
            raise ContactSimError("the MuJoCo closed loop does not model grip-command noise (grip_noise_snr_db)")
        noise = NoiseSource(np.random.default_rng(seed), 1, False)
        self.ft = WristForceSensor(config.sensors, ScalarBackend, 1, noise)
        self.optical = OpticalMotionSensor(config.sensors, ScalarBackend, 1, noise)
        self.ft.sample(*initial_load_n)
        self._ft_every = config.every(config.sensors.ft_rate_hz)
        self._opt_every = config.every(config.sensors.optical_report_rate_hz)
        o = config.obj
        self._face = (o.optical_face_x_m, o.optical_face_y_m, config.sensors.optical_max_gap_m)

    def visible(self, x_m: float, y_m: float, left: bool, pad_gap_m: float) -> bool:
        """The optical sensor sees the box's surface (over the face, pads close, not left)."""
        fx, fy, gap = self._face
        return not left and abs(x_m) <= fx and abs(y_m) <= fy and pad_gap_m <= gap

    def after_step(self, step: int, dx_m: float, dy_m: float, speed_m_s: float, visible: bool,
                   load_n: tuple[float, float]) -> None:
        """One plant step done (`step` = steps done so far): accumulate the box's motion
        relative to the pads (m), then take the F/T sample and the optical report when due."""
        self.optical.accumulate(dx_m, dy_m, speed_m_s, visible)
        if step % self._ft_every == 0:
            self.ft.sample(*load_n)
        if step % self._opt_every == 0:
            self.optical.report(visible)

    def sample(self, time_s: float, grip_force_n: float) -> SensorSample:
        """The controller's view now (arrays of shape (1,), as our plant's `sensor_sample`)."""
        opt = self.optical

        def a(v, dtype=float):
            return np.array((v,), dtype=dtype)

        return SensorSample(time_s=time_s, force_x_n=a(self.ft.force_x_n), force_y_n=a(self.ft.force_y_n),
                            accel_y_m_s2=a(opt.accel_y_m_s2), slip_velocity_x_m_s=a(opt.velocity_x_m_s),
                            slip_velocity_y_m_s=a(opt.velocity_y_m_s), optical_valid=a(opt.valid, bool),
                            grip_force_n=a(grip_force_n))


def _command(controller: GripController, sample: SensorSample) -> float:
    """The controller's grip command (N, >= 0), checked as `episode.run_episode` does."""
    cmd = np.ravel(controller.step(sample))
    if cmd.shape != (1,) or not math.isfinite(float(cmd[0])):
        raise ContactSimError(f"controller returned {cmd!r}, expected one finite grip force")
    return max(float(cmd[0]), 0.0)


def run_mujoco_episode(config: SimConfig, receiver: ReceiverParams, controller: GripController,
                       seed: int | np.random.SeedSequence = 0, params: MujocoParams = MujocoParams(),
                       label: str = "") -> EpisodeResult:
    """One closed-loop episode on MuJoCo (module docstring); `config.obj.mu_static` is MuJoCo's
    one friction coefficient. Same call and result as `episode.run_episode` on our plant."""
    if np.ndim(receiver.pull_angle_rad) != 0:
        raise ContactSimError("run_mujoco_episode takes one receiver behaviour")
    if abs(params.timestep_s - config.dt_s) > 1e-12:
        raise ContactSimError(f"MuJoCo's time step {params.timestep_s} s must equal the plant step {config.dt_s} s")
    period = float(getattr(controller, "period_s", 0.01))
    if not (math.isfinite(period) and period > 0):
        raise ContactSimError(f"controller period_s must be > 0, got {period}")
    every, grip_every = max(1, int(round(period / config.dt_s))), config.every(config.gripper.loop_rate_hz)
    n, dt, obj, hand = config.n_steps, config.dt_s, config.obj, config.hand
    ref = [np.broadcast_to(c, (n,)).tolist() for c in reference(np.arange(n) * dt, receiver)]
    controller.reset(1)
    cmd = _command(controller, rest_sample(config, 1))
    act = GripperActuator(config.gripper, dt, ScalarBackend, 1, cmd)
    pinch = MujocoPinch(obj, obj.mu_static, params, hand.mass_kg, (ref[0][0], ref[1][0]))
    fg0, w = act.spring_force_n(), obj.weight_n
    pinch.settle(fg0)
    stuck0 = w <= obj.mu_static * fg0
    sensors = MujocoSensors(config, seed, (0.0, w if stuck0 else obj.mu_static * fg0))
    ext_x, ext_y = pinch.footprint_m()
    x = y = vx = vy = 0.0
    left, rows = False, []
    rows.append((0.0, (_GRASP if stuck0 else _SLIP) if fg0 > 0 else _RELEASE, fg0 if fg0 > 0 else 0.0, 0.0, 0.0,
                 0.0, 0.0, 0.0, False, cmd, 0.0, 0.0, sensors.ft.force_x_n, sensors.ft.force_y_n, True))
    for k in range(1, n + 1):
        if (k - 1) % grip_every == 0:
            act.latch(cmd)
        fg = act.spring_force_n()
        sample = (ref[0][k - 1], ref[1][k - 1], ref[2][k - 1], ref[3][k - 1], ref[4][k - 1], ref[5][k - 1])
        f_obj, f_hand, holds = receiver_forces(sample, (x, y, vx, vy), pinch.hand_state(), receiver, hand)
        pinch.step(fg, f_obj, f_hand)
        nx, ny, nvx, nvy = pinch.object_state()
        left = left or abs(nx) > ext_x or abs(ny) > ext_y
        speed = math.hypot(nvx, nvy)
        press = 0.0 if left else max(pinch.pad_press_n(), 0.0)
        mode = _RELEASE if press <= 0.0 else (_SLIP if speed > SLIP_SPEED_M_S else _GRASP)
        visible = sensors.visible(nx, ny, left, act.gap_m())
        sensors.after_step(k, nx - x, ny - y, speed, visible, pinch.pad_load_n())
        act.move()
        ay = (nvy - vy) / dt
        x, y, vx, vy = nx, ny, nvx, nvy
        if k % every == 0:
            cmd = _command(controller, sensors.sample(k * dt, act.spring_force_n()))
        rows.append((k * dt, mode, press, f_obj[0], f_obj[1], x, y, ay, holds, cmd, vx, vy,
                     sensors.ft.force_x_n, sensors.ft.force_y_n, sensors.optical.valid))
    return _result(rows, config, label)


def _result(rows: list[tuple], config: SimConfig, label: str) -> EpisodeResult:
    cols = dict(zip(_FIELDS, zip(*rows)))
    arrays = {k: np.asarray(v, dtype=np.int8 if k == "mode" else bool if k in ("receiver_holds", "optical_valid")
                            else float) for k, v in cols.items()}
    trace = EpisodeTrace(**arrays, label=label)
    return EpisodeResult(trace=trace, outcome=outcome_from_trace(trace, config.drop_distance_m))


def holds_at_release(trace: EpisodeTrace) -> bool:
    """The receiver held the object when the final release started (False if never released):
    what `services.studies.gripper.attribution` records for a drop after a handover."""
    mode = np.asarray(trace.mode)
    if mode.size == 0 or mode[-1] != _RELEASE:
        return False
    before = np.flatnonzero(mode != _RELEASE)
    first = 0 if before.size == 0 else int(before[-1]) + 1
    return bool(np.asarray(trace.receiver_holds)[first])
