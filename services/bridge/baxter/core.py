"""Pure logic of the Baxter backend: safety checks, unit and frame conversions, dry-run text.

No I/O and no clock: callers pass times (local `time.monotonic()`, s) and messages.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from services.bridge.baxter.messages import AssemblyState, EndEffectorCommand, JointState
from services.bridge.baxter.ros1 import Ros1Message, md5sum

# --------------------------------------------------------------------------- robot state


def robot_state_problem(state: AssemblyState | None) -> str:
    """Why the robot may not be commanded ("" when it is enabled and not stopped)."""
    if state is None:
        return "no robot state received"
    if state.stopped:
        source = {1: "the e-stop button", 2: "an unknown source", 3: "a joint fault",
                  4: "a lapse of the brain heartbeat"}.get(state.estop_source, "an unknown source")
        return f"the robot is stopped (e-stop by {source}); release it and reset the robot"
    if state.error:
        return "the robot reports an error; reset it (enable_robot.py -r) and enable it"
    if not state.enabled:
        return "the robot is not enabled; enable it (rosrun baxter_tools enable_robot.py -e)"
    return ""


# --------------------------------------------------------------------------- joints


def select_joints(msg: JointState, joint_names: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Positions, velocities and efforts of `joint_names` from a joint-state message.

    Baxter publishes ``/robot/joint_states`` from two nodes: the arms (all 17 joints) and the
    end effectors (gripper joints only). A message without all the arm's joints, or with
    arrays that do not match its names, or with non-finite positions, is not an arm reading:
    None. Missing velocities or efforts read as zeros.
    """
    names = msg.name
    if len(msg.position) != len(names):
        return None
    index = {name: i for i, name in enumerate(names)}
    try:
        rows = [index[name] for name in joint_names]
    except KeyError:
        return None
    position = np.array([msg.position[i] for i in rows], float)
    if not np.all(np.isfinite(position)):
        return None

    def optional(values: Sequence[float]) -> np.ndarray:
        if len(values) != len(names):
            return np.zeros(len(rows))
        out = np.array([values[i] for i in rows], float)
        return np.where(np.isfinite(out), out, 0.0)

    return position, optional(msg.velocity), optional(msg.effort)


@dataclass(frozen=True)
class ClampResult:
    """A command after the hardware clamps.

    Attributes:
        target_rad: what will be sent (7,), rad.
        limited: joints moved inside the (margin-shrunk) limits.
        stepped: joints pulled toward the measured position (target too far away).
    """

    target_rad: np.ndarray
    limited: tuple[int, ...]
    stepped: tuple[int, ...]


def clamp_command(target_rad: np.ndarray, measured_rad: np.ndarray, lower_rad: np.ndarray,
                  upper_rad: np.ndarray, margin_rad: float, max_step_rad: float) -> ClampResult:
    """Clamp a position command to the joint limits shrunk by `margin_rad`, then to within
    `max_step_rad` of the measured position (rad)."""
    target = np.asarray(target_rad, float)
    lo, hi = lower_rad + margin_rad, upper_rad - margin_rad
    inside = np.clip(target, lo, hi)
    limited = tuple(int(i) for i in np.flatnonzero(np.abs(inside - target) > 1e-12))
    measured = np.asarray(measured_rad, float)
    stepped_target = np.clip(inside, measured - max_step_rad, measured + max_step_rad)
    stepped = tuple(int(i) for i in np.flatnonzero(np.abs(stepped_target - inside) > 1e-12))
    return ClampResult(np.clip(stepped_target, lo, hi), limited, stepped)


# --------------------------------------------------------------------------- gripper


def grip_percent(grip_force_n: float, full_scale_n: float) -> float:
    """Grip force (N) as the gripper's force setting, 0–100 %."""
    if not math.isfinite(grip_force_n):
        return 0.0
    return float(min(100.0, max(0.0, 100.0 * grip_force_n / full_scale_n)))


def grip_force_from_percent(percent: float, full_scale_n: float) -> float:
    """Inverse of `grip_percent` (N)."""
    return float(min(100.0, max(0.0, percent))) * full_scale_n / 100.0


def gripper_go_command(grip_force_n: float, full_scale_n: float, gripper_id: int,
                       sequence: int, sender: str = "handover-bridge") -> EndEffectorCommand:
    """A ``go`` command closing the gripper (position 0 %) with the force setting for
    `grip_force_n`; zero force opens it (position 100 %) to release."""
    percent = grip_percent(grip_force_n, full_scale_n)
    position = 0.0 if percent > 0.0 else 100.0
    args = json.dumps({"position": position, "force": round(percent, 3)}, sort_keys=True)
    return EndEffectorCommand(id=gripper_id, command=EndEffectorCommand.CMD_GO, args=args,
                              sender=sender, sequence=sequence)


def parse_gripper_args(args: str) -> tuple[float, float]:
    """(position %, force %) from a ``go`` command's JSON args.

    Raises:
        ValueError: not a JSON object with numeric ``position``/``force`` in 0–100.
    """
    data = json.loads(args) if args else {}
    if not isinstance(data, dict):
        raise ValueError("gripper args are not a JSON object")
    position = float(data.get("position", 100.0))
    force = float(data.get("force", 30.0))
    for name, value in (("position", position), ("force", force)):
        if not (math.isfinite(value) and 0.0 <= value <= 100.0):
            raise ValueError(f"gripper {name} {value!r} is not in 0–100 %")
    return position, force


class GripperThrottle:
    """Decides when a grip command goes to the gripper: a change beyond the dead band, at
    most once per `min_interval_s`; a release (0 N) always goes at once."""

    def __init__(self, min_interval_s: float, deadband_percent: float) -> None:
        self.min_interval_s = min_interval_s
        self.deadband_percent = deadband_percent
        self._sent_percent: float | None = None
        self._sent_s = -math.inf

    def should_send(self, percent: float, now_s: float) -> bool:
        if self._sent_percent is not None and abs(percent - self._sent_percent) <= self.deadband_percent:
            if not (percent == 0.0 and self._sent_percent != 0.0):
                return False
        if percent != 0.0 and now_s - self._sent_s < self.min_interval_s:
            return False
        self._sent_percent = percent
        self._sent_s = now_s
        return True


# --------------------------------------------------------------------------- sensors


class WrenchConverter:
    """F/T sensor frame → gripper frame of the transfer loop, minus a tare bias.

    Args:
        rotation: 3×3, rows: gripper axes in sensor coordinates (v_gripper = R v_sensor).
        tare_samples: samples averaged as the bias before any reading is returned (0: none).
    """

    def __init__(self, rotation: Sequence[Sequence[float]], tare_samples: int = 0) -> None:
        self.rotation = np.array(rotation, float)
        self.tare_samples = int(tare_samples)
        self._sum_force = np.zeros(3)
        self._sum_torque = np.zeros(3)
        self._count = 0
        self.bias_force_n = np.zeros(3)
        self.bias_torque_nm = np.zeros(3)

    @property
    def tared(self) -> bool:
        return self._count >= self.tare_samples

    def convert(self, force_n: Sequence[float], torque_nm: Sequence[float]) -> tuple[np.ndarray, np.ndarray] | None:
        """Gripper-frame force (N) and torque (N m), or None while taring or on a
        non-finite sample."""
        force = self.rotation @ np.asarray(force_n, float)
        torque = self.rotation @ np.asarray(torque_nm, float)
        if not (np.all(np.isfinite(force)) and np.all(np.isfinite(torque))):
            return None
        if not self.tared:
            self._sum_force += force
            self._sum_torque += torque
            self._count += 1
            if self.tared:
                self.bias_force_n = self._sum_force / self._count
                self.bias_torque_nm = self._sum_torque / self._count
            return None
        return force - self.bias_force_n, torque - self.bias_torque_nm


@dataclass(frozen=True)
class OpticalSample:
    """One optical sensor message in the gripper frame: counts, period (s), tracked."""

    dx_counts: float
    dy_counts: float
    dt_s: float
    surface_valid: bool


class OpticalEstimator:
    """Slip velocity and a_y from optical counts, as the simulated sensor estimates them
    (`robot_sim.contact.sensors.OpticalMotionSensor`): v = counts / (counts_per_m · dt),
    a_y = Δv_y / dt, optionally low-passed (first order, `accel_filter_hz`).

    Args:
        rotation: 2×2, sensor x, y → gripper x, y.
        counts_per_m: resolution, counts/m.
        accel_filter_hz: low-pass cut-off on a_y, Hz (0: none).
    """

    def __init__(self, rotation: Sequence[Sequence[float]], counts_per_m: float, accel_filter_hz: float = 0.0) -> None:
        self.rotation = np.array(rotation, float)
        self.counts_per_m = float(counts_per_m)
        self.accel_filter_hz = float(accel_filter_hz)
        self._vy_prev: float | None = None
        self._accel = 0.0

    def to_gripper(self, dx_counts: int, dy_counts: int, dt_s: float, quality: int, min_quality: int) -> OpticalSample:
        d = self.rotation @ np.array([dx_counts, dy_counts], float)
        valid = quality >= min_quality
        return OpticalSample(float(d[0]) if valid else 0.0, float(d[1]) if valid else 0.0, float(dt_s), valid)

    def combine(self, samples: Sequence[OpticalSample]) -> dict[str, object] | None:
        """`sensors/object_motion` fields for the samples of one tick (None if no sample).

        Counts and time add up; the surface is valid only when every sample was.
        """
        samples = [s for s in samples if math.isfinite(s.dt_s) and s.dt_s > 0.0]
        if not samples:
            return None
        dt_s = min(1.0, sum(s.dt_s for s in samples))
        dx = sum(s.dx_counts for s in samples)
        dy = sum(s.dy_counts for s in samples)
        valid = all(s.surface_valid for s in samples)
        vx = dx / self.counts_per_m / dt_s
        vy = dy / self.counts_per_m / dt_s
        if valid and self._vy_prev is not None:
            raw = (vy - self._vy_prev) / dt_s
            if self.accel_filter_hz > 0:
                alpha = 1.0 - math.exp(-2.0 * math.pi * self.accel_filter_hz * dt_s)
                self._accel += alpha * (raw - self._accel)
            else:
                self._accel = raw
        else:
            self._accel = 0.0
        self._vy_prev = vy if valid else None
        clip16 = lambda v: int(max(-32768, min(32767, round(v))))  # noqa: E731
        return {
            "displacement_counts": (clip16(dx), clip16(dy)),
            "counts_per_m": self.counts_per_m,
            "dt_s": max(dt_s, 1e-6),
            "surface_valid": valid,
            "velocity_m_s": (float(np.clip(vx, -1e3, 1e3)), float(np.clip(vy, -1e3, 1e3))),
            "accel_y_m_s2": float(np.clip(self._accel, -1e4, 1e4)),
        }


# --------------------------------------------------------------------------- dry run


def describe(key: str, msg: Ros1Message, payload: bytes) -> str:
    """One line saying what would be sent: topic key, type, MD5, size, fields, bytes (hex,
    first 48)."""
    body = ", ".join(f"{k}={_short(v)}" for k, v in vars(msg).items())
    head = payload[:48].hex()
    more = "…" if len(payload) > 48 else ""
    return f"{msg.TYPE} [{md5sum(msg.TYPE)}] {len(payload)} B on {key}: {body} | {head}{more}"


def _short(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.4f}"
    if isinstance(value, tuple):
        return "[" + ", ".join(_short(v) for v in value) + "]"
    if isinstance(value, str):
        return repr(value)
    return str(value)
