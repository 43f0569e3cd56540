"""Gripper service logic, pure (no bus, no clock of its own): freshness, fail-safe hold,
controller stepping at the configured rate, mode, release latch, force → position.

The node feeds what arrives from the bus (`offer_wrench`, `offer_motion`, `note_rejected`)
with the local receive time, asks `due(now_s)` whether a control tick is due, and calls
`tick(now_s)`, which returns a `GripDecision` to publish. Times are local monotonic seconds.

Fail-safe rules (DESIGN §6, §8):
- The controller runs only on fresh data: wrist wrench younger than `wrench_timeout_s` and
  (when the controller needs it) object motion younger than `motion_timeout_s`.
- Missing, stale or undecodable sensor data, or a controller that raises or returns a
  non-finite force: the service HOLDS. Holding never opens the gripper: the command is
  the last command, raised to at least `hold_grip_force_n` before the release (after the
  release the gripper stays where it is). The state says why (`mode = "hold"`, `reason`).
- The release is declared once the command has been 0 N for `release_confirm_s`; it is
  then latched (the command stays 0 N, one release event) until `rearm()`.

Rate handling: the controller steps on a grid of 1/rate_hz, as soon as a new wrench sample
has arrived once its grid point is near (up to a quarter period early, so jitter adds no
latency; the average rate stays rate_hz, and 1 kHz input steps on every sample at 1 kHz);
with no new sample a watchdog tick runs every 1/rate_hz so staleness is noticed and
reported even when the sensors go silent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from handover_model.grip import Mode, SensorSample
from services.gripper.config import GripperConfig
from services.gripper.controllers.common import ModeReportingController
from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.gripper.spring import GripSpring
from services.runtime.repeat import HOLD_REPEAT_S

__all__ = ["GripDecision", "GripperCore", "MotionReading", "WrenchReading", "MODE_NAMES"]

#: Controller modes as the bus spells them (`bus_schema.messages.GripperMode`).
MODE_NAMES = {int(Mode.GRASP): "grasp", int(Mode.SLIP): "slip", int(Mode.RELEASE): "release"}
#: Steps follow a grid of one period; a new sample may be acted on up to this fraction of
#: a period before its grid point, so that sensor jitter at the control rate adds no
#: latency while the average step rate stays exactly rate_hz.
_EARLY_FRACTION = 0.25


@dataclass(frozen=True)
class WrenchReading:
    """Wrist force in the gripper frame (x toward the receiver, y down), N, with its local
    receive time `rx_s` (monotonic s)."""

    force_x_n: float
    force_y_n: float
    rx_s: float


@dataclass(frozen=True)
class MotionReading:
    """Optical-sensor estimates (gripper frame): a_y (m/s², down +), slip velocity (m/s),
    whether the object surface is over the sensor, and the local receive time `rx_s`."""

    accel_y_m_s2: float
    slip_velocity_x_m_s: float
    slip_velocity_y_m_s: float
    surface_valid: bool
    rx_s: float


@dataclass(frozen=True)
class GripDecision:
    """What one tick decided (everything the node publishes).

    Attributes:
        grip_force_n: grip force command, N (0 ≤ F ≤ max_grip_force_n).
        position_m: gripper position giving that force through the spring (eq 3.21), m.
        mode: ``grasp``, ``slip``, ``release`` (controller's estimate) or ``hold``.
        reason: why the service holds (empty otherwise, ``released`` once latched).
        sensors_fresh: wrench (and motion, when required) are fresh.
        released: the release is latched.
        release_event: this tick latched the release (publish the event once).
        stepped: the controller ran this tick.
        pull_force_n: latest F_sx, N (0 before any wrench).
    """

    grip_force_n: float
    position_m: float
    mode: str
    reason: str
    sensors_fresh: bool
    released: bool
    release_event: bool
    stepped: bool
    pull_force_n: float


def _fmt_age(age_s: float) -> str:
    return "never received" if math.isinf(age_s) else f"stale for {age_s:.3f} s"


class GripperCore:
    """The service's decision logic for one gripper (one episode, n = 1).

    Args:
        config: validated service config.
        controller: a `ModeReportingController` to use instead of building `config.controller`
            (tests); its `period_s` should be `config.period_s`.
    """

    def __init__(self, config: GripperConfig, controller: ModeReportingController | None = None) -> None:
        self.config = config
        self.controller = controller or make_controller(
            config.controller, period_s=config.period_s, **dict(config.controller_params)
        )
        self.spring = GripSpring(
            stiffness_n_m=config.spring_stiffness_n_m,
            contact_position_m=config.contact_position_m,
            max_position_m=config.max_position_m,
        )
        self._start_s: float | None = None
        self._wrench: WrenchReading | None = None
        self._motion: MotionReading | None = None
        self._rejected = {"wrist_wrench": 0, "object_motion": 0}
        #: The supervisor's grip request; without a supervisor the controller runs.
        self.request = "transfer"
        self.rearm()

    # ------------------------------------------------------------------ inputs
    def rearm(self) -> None:
        """Fresh episode: reset the controller and the release latch (sensors are kept)."""
        self.controller.reset(1)
        self.released = False
        self.last_command_n = float(self.config.hold_grip_force_n)
        self._zero_since_s: float | None = None
        self._failure_reason: str | None = None  # last controller failure, until a step succeeds
        self._new_wrench = False
        self._new_motion = False
        self._next_step_s = -math.inf
        self._last_tick_s = -math.inf
        self._episode_start_s: float | None = None
        self.steps = 0
        self.holds = 0

    def set_request(self, request: str) -> None:
        """What the supervisor asks (`SupervisorState.grip_request`): ``open`` (no object:
        command 0 N), ``carry`` (hold firmly at `hold_grip_force_n`: pick and carry, or a
        failed transfer), ``transfer`` (run the fail-safe controller). Entering ``transfer``
        re-arms the controller, so it starts from the load it holds at that moment."""
        if request not in ("open", "carry", "transfer"):
            raise GripperError(f"unknown grip request {request!r}; use open, carry or transfer")
        if request == "transfer" and self.request != "transfer":
            self.rearm()
        self.request = request

    def offer_wrench(self, reading: WrenchReading) -> None:
        """A wrist-wrench sample arrived (decoded)."""
        self._wrench = reading
        self._new_wrench = True

    def offer_motion(self, reading: MotionReading) -> None:
        """An object-motion sample arrived (decoded)."""
        self._motion = reading
        self._new_motion = True

    def note_rejected(self, stream: str, total_rejected: int) -> None:
        """The bus rejected undecodable payloads on `stream` (``wrist_wrench`` or
        ``object_motion``); `total_rejected` is the subscription's running count."""
        if stream not in self._rejected:
            raise GripperError(f"unknown sensor stream {stream!r}; use wrist_wrench or object_motion")
        self._rejected[stream] = int(total_rejected)

    @property
    def has_new_wrench(self) -> bool:
        """A wrench sample arrived since the last controller step."""
        return self._new_wrench

    @property
    def wrench_rx_s(self) -> float | None:
        """Local receive time of the newest wrench sample (monotonic s), None before any."""
        return None if self._wrench is None else self._wrench.rx_s

    # ------------------------------------------------------------------ timing
    @property
    def releasing(self) -> bool:
        """The controller runs (request ``transfer``): every wrench sample may change the grip.
        Otherwise (``open``, ``carry``) the command is fixed until the request changes."""
        return self.request == "transfer"

    def _period_s(self) -> float:
        """Tick period: the control period while releasing; at rest, the period of the hold
        command's copies (`HOLD_REPEAT_S`): nothing a tick computes can change sooner."""
        period = self.config.period_s
        return period if self.releasing else max(period, HOLD_REPEAT_S)

    def due(self, now_s: float) -> bool:
        """Whether `tick` should run now: while releasing, a new wrench sample and the step
        grid point is at most a quarter period away; or a whole period since the last tick
        (watchdog)."""
        period = self.config.period_s
        if self.releasing and self._new_wrench and now_s >= self._next_step_s - _EARLY_FRACTION * period:
            return True
        return now_s - self._last_tick_s >= self._period_s()

    def next_due_s(self, now_s: float) -> float:
        """Seconds until `due` can next become true without new data (for the node's wait)."""
        wait = self._last_tick_s + self._period_s() - now_s
        if self.releasing and self._new_wrench:
            wait = min(wait, self._next_step_s - _EARLY_FRACTION * self.config.period_s - now_s)
        return max(0.0, wait)

    # ------------------------------------------------------------------ freshness
    def _stale_reasons(self, now_s: float) -> list[str]:
        reasons = []
        cfg = self.config
        checks: list[tuple[str, WrenchReading | MotionReading | None, float]] = [
            ("wrist_wrench", self._wrench, cfg.wrench_timeout_s)]
        if cfg.require_motion:
            checks.append(("object_motion", self._motion, cfg.motion_timeout_s))
        for name, reading, timeout in checks:
            age = math.inf if reading is None else now_s - reading.rx_s
            if age > timeout:
                text = f"{name} {_fmt_age(age)}"
                if self._rejected[name]:
                    text += f" ({self._rejected[name]} undecodable payloads so far)"
                reasons.append(text)
        return reasons

    # ------------------------------------------------------------------ the tick
    def _sample(self, now_s: float) -> SensorSample:
        w = self._wrench
        assert w is not None
        m = self._motion
        if m is not None and now_s - m.rx_s > self.config.motion_timeout_s:
            m = None  # stale: as if none had come
        valid = m is not None and bool(m.surface_valid)
        if self._episode_start_s is None:
            self._episode_start_s = now_s
        one = lambda v: np.array([float(v)])  # noqa: E731
        return SensorSample(
            time_s=now_s - self._episode_start_s,
            force_x_n=one(w.force_x_n),
            force_y_n=one(w.force_y_n),
            accel_y_m_s2=one(m.accel_y_m_s2 if m is not None and valid else 0.0),
            slip_velocity_x_m_s=one(m.slip_velocity_x_m_s if m is not None and valid else 0.0),
            slip_velocity_y_m_s=one(m.slip_velocity_y_m_s if m is not None and valid else 0.0),
            optical_valid=np.array([valid]),
            grip_force_n=one(self.last_command_n),
            force_fresh=self._new_wrench,
            optical_fresh=self._new_motion,
        )

    def _hold(self, reason: str, fresh: bool) -> GripDecision:
        self.holds += 1
        self._zero_since_s = None
        if self.released:
            force = self.last_command_n
        else:
            force = max(self.last_command_n, self.config.hold_grip_force_n)
        force = min(force, self.config.max_grip_force_n)
        self.last_command_n = force
        return self._decision(force, "hold", reason, fresh, stepped=False)

    def _decision(self, force: float, mode: str, reason: str, fresh: bool, stepped: bool,
                  release_event: bool = False) -> GripDecision:
        pull = self._wrench.force_x_n if self._wrench is not None else 0.0
        return GripDecision(
            grip_force_n=force,
            position_m=float(self.spring.position_m(force)),
            mode=mode,
            reason=reason,
            sensors_fresh=fresh,
            released=self.released,
            release_event=release_event,
            stepped=stepped,
            pull_force_n=float(pull),
        )

    def tick(self, now_s: float) -> GripDecision:
        """One control tick at local time `now_s` (monotonic s)."""
        self._last_tick_s = now_s
        stale = self._stale_reasons(now_s)
        fresh = not stale
        if self.request != "transfer":
            self._new_wrench = self._new_motion = False
            if self.request == "open":
                self.last_command_n = 0.0
                return self._decision(0.0, "release", "open (supervisor: no object)", fresh, stepped=False)
            force = min(self.config.hold_grip_force_n, self.config.max_grip_force_n)
            self.last_command_n = force
            return self._decision(force, "grasp", "carry (supervisor)", fresh, stepped=False)
        if self.released:
            self._new_wrench = self._new_motion = False
            return self._decision(self.last_command_n, "release", "released", fresh, stepped=False)
        if stale:
            return self._hold("; ".join(stale), fresh=False)
        if not self._new_wrench:
            # Fresh but nothing new since the last step (watchdog tick): keep the command, and
            # keep reporting a controller failure until a step succeeds.
            if self._failure_reason is not None:
                return self._decision(self.last_command_n, "hold", self._failure_reason, True, stepped=False)
            mode = MODE_NAMES.get(int(self.controller.mode[0]), "grasp") if self.steps else "grasp"
            return self._decision(self.last_command_n, mode, "", True, stepped=False)
        sample = self._sample(now_s)
        try:
            command = np.asarray(self.controller.step(sample), dtype=float).reshape(-1)
            force = float(command[0])
        except (GripperError, ValueError, IndexError, FloatingPointError) as exc:
            self._failure_reason = f"controller {self.config.controller} failed: {exc}"
            return self._hold(self._failure_reason, fresh=True)
        finally:
            self._new_wrench = self._new_motion = False
        if not math.isfinite(force):
            self._failure_reason = f"controller {self.config.controller} returned a non-finite force"
            return self._hold(self._failure_reason, fresh=True)
        self._failure_reason = None
        period = self.config.period_s
        grid_s = self._next_step_s if now_s - self._next_step_s < period else now_s  # resync after a gap
        self._next_step_s = grid_s + period
        self.steps += 1
        force = min(max(force, 0.0), self.config.max_grip_force_n)
        self.last_command_n = force
        mode = MODE_NAMES.get(int(self.controller.mode[0]), "grasp")
        if force > 0.0:
            self._zero_since_s = None
            return self._decision(force, "release" if mode == "release" else mode, "", True, stepped=True)
        if self._zero_since_s is None:
            self._zero_since_s = now_s
        if now_s - self._zero_since_s >= self.config.release_confirm_s:
            self.released = True
            return self._decision(0.0, "release", "released", True, stepped=True, release_event=True)
        return self._decision(0.0, "release", "", True, stepped=True)
