"""Backends of the bridge behind one interface: the simulated arm, or the Baxter hardware backend.

A backend owns the robot (real or simulated). The bridge node calls, once per tick:
`step(dt_s)`, then `command(target_rad)` or `hold()`, then `read()`. Extra publications of a
backend (sensors, ground truth) come through `publish_extras(publish)` so that the contact
physics and the hardware sensors slot in without touching the node.
"""

from __future__ import annotations

import math

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from robot_sim.arm import SimulatedArm
from handover_model import robots
from handover_model.robots import JointLimits


@dataclass(frozen=True)
class JointReading:
    """Measured joints (rad, rad/s, N m) in `Backend.joint_names` order."""

    position_rad: np.ndarray
    velocity_rad_s: np.ndarray
    effort_nm: np.ndarray


#: Bound of the optical sensor's 16-bit displacement counts.
INT16_MAX = 32767


def clip_finite(value: float, bound: float) -> float:
    """`value` clipped to [−bound, bound]; a NaN or infinite value becomes 0 (a simulator
    glitch must not reach the bus, whose fields are bounded)."""
    value = float(value)
    if -bound < value < bound:  # the usual case, in one comparison (NaN fails it)
        return value
    if not math.isfinite(value):
        return 0.0
    return max(-bound, min(bound, value))


#: publish(topic_suffix, fields) → publishes a message of that topic with the given fields.
PublishFn = Callable[[str, dict[str, Any]], None]


class Backend(Protocol):
    """What the bridge node needs from a robot."""

    name: str
    joint_names: tuple[str, ...]
    limits: JointLimits

    def step(self, dt_s: float) -> None:
        """Advance the robot by `dt_s` (simulation) or poll it (hardware)."""

    def catch_up(self, gap_s: float) -> None:
        """The bridge's loop did not run for `gap_s` seconds (starved of CPU or frozen): bring
        the robot to now as it would have gone on meanwhile, before this tick's commands
        (hardware: nothing to do, the robot lived through the gap)."""

    def command(self, target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None = None) -> None:
        """Servo toward `target_rad` (validated and inside limits) moving at `feedforward_rad_s`."""

    def hold(self) -> None:
        """Hold the current position."""

    def read(self) -> JointReading:
        """The latest measured joint state."""

    def publish_extras(self, publish: PublishFn) -> None:
        """Publish backend-specific data (sensors, ground truth) for this tick."""

    def gripper_command(self, grip_force_n: float) -> None:
        """Apply a grip-force command (N); backends without a gripper ignore it."""

    @property
    def enabled(self) -> bool:
        """The robot reports that it can move (hardware: enabled and not stopped)."""

    def new_episode(self) -> None:
        """The supervisor started a new episode: reset what a simulated scene keeps per episode
        (hardware: nothing to do)."""

    def episode_running(self, running: bool) -> None:
        """Whether the supervisor's newest state is inside an episode (a simulated scene may
        let its still physics sleep outside one; hardware: nothing to do)."""

    def close(self) -> None:
        """Release the robot."""


class SimBackend:
    """The active arm simulated by `robot_sim.arm.SimulatedArm` in real time.

    A servo step that would leave the arm exactly as it is (the same positions and
    velocities) is not computed again while its inputs stay the same (the state, target and
    feed-forward bit for bit, and the step's dt or any dt up to a bound proven from the servo's
    equations: unbounded when the arm rests exactly on its target with no feed-forward, a few
    ms when it settled a hair short of it), and a command equal to the one the servo already
    has is not clipped again: the arm's state is what it would have been, bit for bit
    (`tests/unit/bridge/test_handover_equivalence.py`).
    """

    name = "sim"

    def __init__(self, time_constant_s: float = 0.05,
                 initial_position_rad: np.ndarray | None = None,
                 robot_command_timeout_s: float = 0.2) -> None:
        self.joint_names = robots.active().joints
        self.limits = robots.arm_model().limits
        self.arm = SimulatedArm(time_constant_s, self.limits, initial_position_rad)
        self.robot_command_timeout_s = float(robot_command_timeout_s)
        self._holding_target: np.ndarray | None = None
        #: (state, its dt, inputs, longest dt proven to change nothing) of a step that changed nothing
        self._at_rest: tuple | None = None
        self._commanded: tuple | None = None  # (command bytes, the target and feed-forward arrays it set)

    def step(self, dt_s: float) -> None:
        arm = self.arm
        before = arm.state
        inputs = (arm.target_rad.tobytes(), arm.feedforward_rad_s.tobytes(), arm.time_constant_s)
        rest = self._at_rest
        if (rest is not None and rest[0] is before and rest[2] == inputs
                and (rest[1] == dt_s or (0.0 < dt_s <= rest[3] and dt_s < math.inf))):
            return  # a step with these inputs changed nothing: it would change nothing again
        arm.step(dt_s)
        after = arm.state
        self._at_rest = None
        q = before.position_rad.tobytes()
        if (after is not before and after.position_rad.tobytes() == q
                and after.velocity_rad_s.tobytes() == before.velocity_rad_s.tobytes()):
            # For this dt, and for any dt up to the bound its equations prove
            # (`SimulatedArm.still_for_dt_up_to_s`): unbounded when it rests exactly on its
            # target with no feed-forward, a few ms when it settled a few units in the last
            # place short of it (the loop's jitter moves dt every tick).
            self._at_rest = (after, dt_s, inputs, arm.still_for_dt_up_to_s())

    def catch_up(self, gap_s: float) -> None:
        """The simulated robot did not stop when the bridge stalled: like the default arm's own
        controller it goes on toward the last position command for up to
        `robot_command_timeout_s`, then holds for the rest of the gap (the scene, if any,
        advances with it). The command's velocity feed-forward is not carried on: it belongs to
        a streamed trajectory that stopped coming (its position mode servoes to the last
        position it was given)."""
        if gap_s <= 0.0:
            return
        going_on_s = min(gap_s, self.robot_command_timeout_s)
        self.arm.set_target(self.arm.target_rad.copy(), None)
        self._commanded = None
        self.step(going_on_s)
        if gap_s > going_on_s:
            self.hold()
            self.step(gap_s - going_on_s)

    def command(self, target_rad: np.ndarray, feedforward_rad_s: np.ndarray | None = None) -> None:
        self._holding_target = None
        arm = self.arm
        key = _command_bytes(target_rad, feedforward_rad_s)
        done = self._commanded
        if (key is not None and done is not None and done[0] == key
                and done[1] is arm.target_rad and done[2] is arm.feedforward_rad_s):
            return  # the servo already has this very command (the same bytes, not changed since)
        arm.set_target(target_rad, feedforward_rad_s)
        self._commanded = None if key is None else (key, arm.target_rad, arm.feedforward_rad_s)

    def hold(self) -> None:
        # Latch the position at the moment the hold starts, so the arm stays there.
        if self._holding_target is None:
            self.arm.hold()
            self._holding_target = self.arm.target_rad.copy()

    def read(self) -> JointReading:
        state = self.arm.state
        return JointReading(
            position_rad=state.position_rad.copy(),
            velocity_rad_s=state.velocity_rad_s.copy(),
            effort_nm=np.zeros(state.position_rad.shape),
        )

    def publish_extras(self, publish: PublishFn) -> None:
        return None

    @property
    def enabled(self) -> bool:
        """A simulated arm can always move."""
        return True

    def new_episode(self) -> None:
        """The bare arm keeps nothing per episode (the handover scene does)."""
        return None

    def episode_running(self, running: bool) -> None:
        """Nothing of the bare arm sleeps between episodes."""
        return None

    def gripper_command(self, grip_force_n: float) -> None:
        return None

    def close(self) -> None:
        return None


def _command_bytes(target_rad: Any, feedforward_rad_s: Any) -> tuple | None:
    """A joint command's exact shapes and bytes (float64 arrays only; None for anything else)."""
    if type(target_rad) is not np.ndarray or target_rad.dtype != np.float64:
        return None
    if feedforward_rad_s is None:
        return target_rad.shape, target_rad.tobytes(), None
    if type(feedforward_rad_s) is not np.ndarray or feedforward_rad_s.dtype != np.float64:
        return None
    return target_rad.shape, target_rad.tobytes(), feedforward_rad_s.shape, feedforward_rad_s.tobytes()


def _sim_kwargs(kwargs: dict[str, Any]) -> dict[str, Any]:
    """The keyword arguments a simulated arm takes (the hardware-only ones dropped)."""
    return {k: kwargs[k] for k in ("time_constant_s", "initial_position_rad", "robot_command_timeout_s")
            if k in kwargs}


def print_dry_run_line(line: str) -> None:
    """A hardware backend's ``--dry-run`` sink: what it would send, one line on stdout."""
    import sys

    sys.stdout.write(f"[dry-run] {line}\n")
    sys.stdout.flush()


def make_backend(name: str, contact: Any = None, **kwargs: Any) -> Backend:
    """Backend by name (``sim``); with `contact` enabled, the sim runs the contact plant
    (``transfer`` scenario) or the whole handover scene (``handover``, with the receiver's
    body from `contact.height_m` and `contact.posture`)."""
    from services.bridge.errors import BridgeConfigError

    if name == "sim":
        if contact is not None and contact.enabled and contact.scenario == "handover":
            from robot_sim.handover_scene import SceneParams
            from services.bridge.handover_backend import HandoverSimBackend

            params = SceneParams(behaviour=contact.behaviour, receiver=dict(contact.receiver),
                                 pull_angle_deg=contact.pull_angle_deg, object_mass_kg=contact.object_mass_kg,
                                 mu_static=contact.mu_static, mu_kinetic=contact.mu_kinetic, seed=contact.seed,
                                 height_m=contact.height_m, posture=contact.posture,
                                 reach_duration_s=contact.hand_reach_duration_s,
                                 ft_noise_std_n=contact.ft_noise_std_n, ft_bias_std_n=contact.ft_bias_std_n,
                                 object_start_base_m=robots.active().object_pick_base_m,
                                 gripper=robots.active().gripper)
            return HandoverSimBackend(params, **_sim_kwargs(kwargs))
        if contact is not None and contact.enabled:
            from services.bridge.contact_backend import ContactSimBackend

            return ContactSimBackend(
                behaviour=contact.behaviour, pull_angle_deg=contact.pull_angle_deg,
                object_mass_kg=contact.object_mass_kg, mu_static=contact.mu_static,
                mu_kinetic=contact.mu_kinetic, initial_grip_force_n=contact.initial_grip_force_n,
                seed=contact.seed, receiver=dict(contact.receiver), **_sim_kwargs(kwargs))
        return SimBackend(**_sim_kwargs(kwargs))
    if name == "baxter":
        # The real robot: needs the profile (its router carries the ROS 1 topics) and the
        # [services.bridge.config.baxter] table; the sim-only keyword arguments do not apply.
        from services.bridge.baxter.backend import BaxterBackend

        if kwargs.get("profile") is None:
            raise BridgeConfigError("the baxter backend needs the deploy profile: run it with "
                                    "`python -m services.bridge.baxter` (see docs/baxter.md)")
        return BaxterBackend(kwargs["profile"], kwargs.get("baxter"), dry_run=bool(kwargs.get("dry_run", False)),
                             dry_run_sink=kwargs.get("dry_run_sink"))
    if name == "franka":
        from services.bridge.franka.backend import FrankaBackend

        return FrankaBackend(kwargs.get("franka"), dry_run=bool(kwargs.get("dry_run", False)),
                             dry_run_sink=kwargs.get("dry_run_sink"))
    raise BridgeConfigError(f"unknown bridge backend {name!r} (known: sim, baxter, franka)")
