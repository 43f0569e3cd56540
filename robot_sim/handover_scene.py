"""The whole simulated handover scene: object on the table, pick, carry, the receiver's reach,
the contact transfer and the object in the receiver's hand. Pure stepping, no bus, no clock.

One receiver drives everything the simulation shows of the human: the simulated Kinect's
body (its right hand) and the contact plant's hand are the same hand.

Phases of the object (`ObjectPhase`):

- ``on_table``: the object waits at `object_start_base_m` (``base`` frame). The F/T sensor
  reads zero and the optical sensor sees no surface.
- ``in_gripper``: the pick. The fingers close on the object when the tool is within
  `grasp_tolerance_m` of it, nearly at rest (`tool_rest_speed_m_s`) and the grip command is
  at least `grasp_min_force_n` (the robot's pick routine closing the fingers). From then on
  `robot_sim.contact.ContactPlant` runs the object between the pads (gravity, friction, the
  gripper's spring and 25 Hz loop, the sensors) with the live gripper commands, first with
  no receiver.
- The receiver watches the object: once the robot presents the lifted object in front of
  them (within `presentation_half_width_m` of the receiving shoulder's vertical x–z plane,
  the task plane, and within the receiver's reach plus `reach_trigger_margin_m` of that
  shoulder), the hand reaches for it (minimum-jerk over `reach_duration_s`, re-aimed at the
  moving object). When the hand has
  arrived and the tool is at rest, the contact begins: the plant's receiver becomes the
  configured behaviour (taking, dropping, bumping, hesitating) on the plant's clock, with
  its reach already done. From then on the hand is the plant's hand.
- The plant decides the rest: the receiver takes the object, the object stays in the
  gripper, or it falls (``dropped``).

Frames: the plant lives in the transfer loop's gripper frame (x toward the receiver = base
+x, y down) with its origin at the grasp point; a plant point (x, y) is the base point
origin + (x, 0, −y). The origin is the live tool position while the object is between the
pads, and stays where the tool was once the object has left them (the receiver holds it,
or it falls), so a retracting arm does not drag the receiver's object along.
The arm's motion does not feed back into the plant (no inertial coupling).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from handover_model import scene
from handover_model.robots import GripperSpec
from robot_sim.contact.config import ContactSimError, ObjectParams, SensorParams, SimConfig
from robot_sim.contact.plant import ContactPlant
from robot_sim.contact.receiver import absent, behaviour_by_name, min_jerk
from robot_sim.kinect.receiver import BodySize, ReceiverBody

ObjectPhase = Literal["on_table", "in_gripper", "with_receiver", "dropped"]
ReceiverPhase = Literal["resting", "reaching", "contact"]

#: The scene's defaults per behaviour, applied before the profile's `receiver` overrides.
#: Dropping is the thesis's dropping (§3.3: the experimenter "tries to touch and pull the mug
#: softly"; §3.5: the pull rises to 2 N over 0.5 s): a 3 N hook built over 0.5 s. The
#: Monte-Carlo benchmark's harsher dropping receivers (up to 20–30 N within 0.1 s) defeat every
#: reacting controller with the simulated actuator (25 Hz loop, 50 N/s): see docs/gripper.md.
SCENE_BEHAVIOUR_DEFAULTS: dict[str, dict[str, float]] = {
    "dropping": {"grasp_strength_n": 3.0, "transfer_s": 0.5},
}

#: Reach time the plant's behaviour factories assume before the grasp starts (s); the scene
#: sets the behaviour's reach start this far back so that the grasp starts at contact.
_PLANT_REACH_DURATION_S = 0.8


@dataclass(frozen=True)
class SceneParams:
    """Everything that defines a simulated handover scene.

    Attributes:
        behaviour: receiver behaviour: taking, dropping, bumping, hesitating or absent.
        receiver: extra parameters of the behaviour (`robot_sim.contact.receiver`).
        pull_angle_deg: pull direction φ, deg (> 0 pulls downward).
        object_mass_kg, mu_static, mu_kinetic: the object and its friction with the pads.
        seed: noise seed of the plant (same seed, same commands → same run).
        height_m, posture: the receiver's body.
        object_start_base_m: object centre on the table at the start (`base`, m).
        grasp_tolerance_m: the fingers close on the object only within this distance, m.
        grasp_min_force_n: grip command that counts as closing the fingers, N.
        tool_rest_speed_m_s: tool speed below which the tool counts as at rest, m/s.
        reach_trigger_margin_m: the receiver reaches once the presented object is within its
            arm reach plus this margin of its receiving shoulder, m.
        presentation_half_width_m: the object counts as presented within this distance
            (along base y) of the receiving shoulder's x–z plane, m.
        reach_duration_s: duration of the receiver's reach, s.
        contact_distance_m: the hand touches the object within this distance, m. (A transfer
            point beyond the straight arm is reached by leaning the upper body, at most 0.04·H,
            as the planner assumes: `robot_sim.kinect.receiver.ReceiverBody.joints`.)
        lift_clearance_m: the object counts as lifted this far above its table position, m.
        ft_noise_std_n, ft_bias_std_n: the wrist F/T sensor's white noise per axis and the
            spread of its per-episode bias, N (`robot_sim.contact.config.SensorParams`).
        gripper: the robot's gripper (its rates and force range go into the plant's actuator);
            None: the plant's default actuator (50 N/s, 25 Hz, 140 N).
    """

    behaviour: str = "taking"
    receiver: dict[str, float] = field(default_factory=dict)
    pull_angle_deg: float = 0.0
    object_mass_kg: float = 0.2
    mu_static: float = 0.6
    mu_kinetic: float = 0.5
    seed: int = 0
    height_m: float = 1.75
    posture: Literal["standing", "sitting"] = "standing"
    object_start_base_m: tuple[float, float, float] = tuple(float(v) for v in scene.OBJECT_PICK_BASE_M)
    grasp_tolerance_m: float = 0.04
    grasp_min_force_n: float = 2.0
    tool_rest_speed_m_s: float = 0.05
    reach_trigger_margin_m: float = 0.25
    presentation_half_width_m: float = 0.15
    reach_duration_s: float = 1.0
    contact_distance_m: float = 0.06
    lift_clearance_m: float = 0.05
    ft_noise_std_n: float = SensorParams.ft_noise_std_n
    ft_bias_std_n: float = SensorParams.ft_bias_std_n
    gripper: GripperSpec | None = None


@dataclass(frozen=True)
class SceneOutput:
    """One step's sensors and truth.

    Sensors (transfer-loop gripper frame, x toward the receiver, y down): `wrist_force_n`
    (F_sx, F_sy), N; the optical sensor (`optical_counts`, `optical_counts_per_m`,
    `optical_dt_s`, `optical_valid`, `slip_velocity_m_s`, `accel_y_m_s2`).
    Truth (`base` frame, m, m/s, N): object position and velocity, who holds it, dropped,
    slip, actual grip force, receiver hand, receiver pull.
    """

    wrist_force_n: tuple[float, float]
    optical_counts: tuple[float, float]
    optical_counts_per_m: float
    optical_dt_s: float
    optical_valid: bool
    slip_velocity_m_s: tuple[float, float]
    accel_y_m_s2: float
    object_phase: ObjectPhase
    receiver_phase: ReceiverPhase
    object_position_m: np.ndarray
    object_velocity_m_s: np.ndarray
    held_by: str
    dropped: bool
    slip_m: float
    grip_force_n: float
    receiver_hand_m: np.ndarray
    receiver_pull_n: float


class HandoverScene:
    """The simulated scene (see the module docstring). Call `step` once per control tick.

    `plant_type` is the contact plant the pick creates (a test may give a subclass)."""

    plant_type: type[ContactPlant] = ContactPlant

    def __init__(self, params: SceneParams) -> None:
        self.params = params
        try:
            self._config = SimConfig(obj=ObjectParams(mass_kg=params.object_mass_kg, mu_static=params.mu_static,
                                                      mu_kinetic=params.mu_kinetic),
                                     sensors=SensorParams(ft_noise_std_n=params.ft_noise_std_n,
                                                          ft_bias_std_n=params.ft_bias_std_n))
            g = params.gripper
            if g is not None:
                self._config = self._config.with_gripper(g.force_rate_n_s, g.loop_rate_hz, g.force_max_n, g.force_min_n)
            # Build the behaviour once now so that a bad configuration fails at start-up.
            self._behaviour_at(10.0)
        except TypeError as exc:
            raise ContactSimError(f"invalid receiver parameters: {exc}") from None
        self.body = ReceiverBody(BodySize(params.height_m, params.posture))
        self._optical_dt_s = float(self._config.every(self._config.sensors.optical_report_rate_hz) * self._config.dt_s)
        self._shoulder_key: bytes | None = None  # the hand position `_shoulder_m` is the shoulder for
        self.episode = 0
        #: Whether the contact physics may sleep once still (`robot_sim.contact.rest`): set by
        #: the caller while no episode runs (nobody judges the physics then); off by default.
        self.may_sleep = False
        self.reset()

    # ------------------------------------------------------------------ set-up
    def reset(self) -> None:
        """Object back on the table, receiver's hand at rest, no plant (a new episode)."""
        self.object_phase: ObjectPhase = "on_table"
        self.receiver_phase: ReceiverPhase = "resting"
        self.object_m = np.array(self.params.object_start_base_m, dtype=float)
        self.object_velocity_m_s = np.zeros(3)
        self.hand_m = self.body.rest_hand_m.copy()
        self.plant: ContactPlant | None = None
        self._updated_for: bytes | None = None  # the tool position of the last update from the plant
        self._origin_m: np.ndarray | None = None
        self._reach_start_hand_m = self.hand_m.copy()
        self._reach_elapsed_s = 0.0
        self.episode += 1

    def _behaviour_at(self, contact_time_s: float):
        p = self.params
        weight_n = p.object_mass_kg * 9.81
        if p.behaviour == "absent":
            return absent(weight_n)
        kwargs: dict[str, Any] = {"weight_n": weight_n, "pull_angle_rad": math.radians(p.pull_angle_deg)}
        if p.behaviour == "bumping":
            kwargs["pull_angle_rad"] = math.pi  # the hand comes from the receiver's side
            kwargs["bump_start_s"] = contact_time_s
        else:
            duration = float(p.receiver.get("reach_duration_s", _PLANT_REACH_DURATION_S))
            kwargs["reach_start_s"] = contact_time_s - duration
            kwargs["reach_duration_s"] = duration
        kwargs.update(SCENE_BEHAVIOUR_DEFAULTS.get(p.behaviour, {}))
        kwargs.update({k: v for k, v in p.receiver.items() if k not in ("reach_start_s", "bump_start_s")})
        return behaviour_by_name(p.behaviour, **kwargs)

    @property
    def receiving_shoulder_m(self) -> np.ndarray:
        """The receiver's right shoulder (`base`, m)."""
        return self.body.joints(self.hand_m)["right_shoulder"]

    # ------------------------------------------------------------------ stepping
    def step(self, dt_s: float, tool_m: np.ndarray, tool_speed_m_s: float, grip_command_n: float) -> SceneOutput:
        """Advance by `dt_s` (s) with the tool at `tool_m` (`base`, m) moving at
        `tool_speed_m_s` and the latest grip command (N)."""
        tool_m = np.asarray(tool_m, dtype=float)
        p = self.params
        grip_command_n = max(0.0, float(grip_command_n)) if math.isfinite(grip_command_n) else 0.0
        if self.object_phase == "on_table":
            near = np.linalg.norm(tool_m - self.object_m) <= p.grasp_tolerance_m
            if near and tool_speed_m_s <= p.tool_rest_speed_m_s and grip_command_n >= p.grasp_min_force_n:
                self.plant = self.plant_type(self._config, absent(p.object_mass_kg * 9.81), seed=p.seed,
                                          initial_grip_force_n=grip_command_n)
                self.object_phase = "in_gripper"
        plant = self.plant
        if plant is not None:
            plant.may_sleep = self.may_sleep
            rest = plant.rest
            plant.run_real_time(dt_s, grip_command_n)  # the state is read from the plant
            tool_key = tool_m.tobytes()
            # Only replayed (a rest or a sleep all through) with the tool where it was: the
            # plant's state and so the scene's are what they were.
            if rest is None or plant.rest is not rest or tool_key != self._updated_for:
                self._update_from_plant(tool_m)
                self._updated_for = tool_key
        self._update_receiver(dt_s, tool_m, tool_speed_m_s)
        return self._output()

    def _update_from_plant(self, tool_m: np.ndarray) -> None:
        plant = self.plant
        assert plant is not None
        in_pads = not bool(plant.left)
        if in_pads or self._origin_m is None:
            self._origin_m = tool_m.copy()
        origin = self._origin_m
        self.object_m = origin + np.array([float(plant.px), 0.0, -float(plant.py)])
        self.object_velocity_m_s = np.array([float(plant.vx), 0.0, -float(plant.vy)])
        if self.receiver_phase == "contact":
            self.hand_m = origin + np.array([float(plant.hx), 0.0, -float(plant.hy)])
        if bool(plant.dropped):
            self.object_phase = "dropped"
        elif not in_pads and bool(plant.holds):
            self.object_phase = "with_receiver"
        elif in_pads:
            self.object_phase = "in_gripper"

    def _update_receiver(self, dt_s: float, tool_m: np.ndarray, tool_speed_m_s: float) -> None:
        p = self.params
        if p.behaviour == "absent" or self.receiver_phase == "contact" or self.object_phase != "in_gripper":
            return
        if self.receiver_phase == "resting":
            if not (self.object_m[2] >= p.object_start_base_m[2] + p.lift_clearance_m):
                return  # not lifted yet
            key = self.hand_m.tobytes()
            if key != self._shoulder_key:  # the body's shoulder moves only with its hand (leaning)
                self._shoulder_key, self._shoulder_m = key, self.receiving_shoulder_m
            shoulder = self._shoulder_m
            presented = abs(float(self.object_m[1] - shoulder[1])) <= p.presentation_half_width_m
            near = float(np.linalg.norm(self.object_m - shoulder)) <= self.body.reach_m + p.reach_trigger_margin_m
            if presented and near:
                self.receiver_phase = "reaching"
                self._reach_start_hand_m = self.hand_m.copy()
                self._reach_elapsed_s = 0.0
            return
        # Reaching: minimum-jerk, re-aimed at the (possibly moving) object.
        self._reach_elapsed_s += dt_s
        s, _ = min_jerk(self._reach_elapsed_s, 0.0, p.reach_duration_s)
        wanted = self._reach_start_hand_m + float(s) * (self.object_m - self._reach_start_hand_m)
        self.hand_m = self.body.joints(wanted)["right_hand"]  # as far as the arm reaches
        reached = np.linalg.norm(self.hand_m - self.object_m) <= p.contact_distance_m
        if reached and self._reach_elapsed_s >= p.reach_duration_s and tool_speed_m_s <= p.tool_rest_speed_m_s:
            assert self.plant is not None
            self.plant.replace_receiver(self._behaviour_at(self.plant.time_s))
            self.receiver_phase = "contact"

    # ------------------------------------------------------------------ outputs
    def _output(self) -> SceneOutput:
        plant = self.plant
        holder = {"on_table": "table", "dropped": "none"}.get(self.object_phase)
        if plant is None:  # on the table, nothing in the gripper
            return SceneOutput(
                wrist_force_n=(0.0, 0.0), optical_counts=(0.0, 0.0),
                optical_counts_per_m=float(self._config.sensors.optical_counts_per_m), optical_dt_s=1e-3,
                optical_valid=False, slip_velocity_m_s=(0.0, 0.0), accel_y_m_s2=0.0,
                object_phase=self.object_phase, receiver_phase=self.receiver_phase,
                object_position_m=self.object_m.copy(), object_velocity_m_s=np.zeros(3), held_by="table",
                dropped=False, slip_m=0.0, grip_force_n=0.0, receiver_hand_m=self.hand_m.copy(),
                receiver_pull_n=0.0,
            )
        # The plant's sensors and truth as its `observation()` reports them (none built here).
        ft, opt = plant.ft, plant.optical
        in_pads = not bool(plant.left) and float(plant.grip_force_n) > 0.0
        receiver = bool(plant.holds)
        if holder is None:
            holder = "both" if in_pads and receiver else "gripper" if in_pads else "receiver" if receiver else "none"
        return SceneOutput(
            wrist_force_n=(float(ft.force_x_n), float(ft.force_y_n)),
            optical_counts=(float(opt.counts_x), float(opt.counts_y)),
            optical_counts_per_m=float(self._config.sensors.optical_counts_per_m), optical_dt_s=self._optical_dt_s,
            optical_valid=bool(opt.valid),
            slip_velocity_m_s=(float(opt.velocity_x_m_s), float(opt.velocity_y_m_s)),
            accel_y_m_s2=float(opt.accel_y_m_s2),
            object_phase=self.object_phase, receiver_phase=self.receiver_phase,
            object_position_m=self.object_m.copy(), object_velocity_m_s=self.object_velocity_m_s.copy(),
            held_by=holder, dropped=bool(plant.dropped), slip_m=float(plant.py),
            grip_force_n=max(0.0, float(plant.grip_force_n)), receiver_hand_m=self.hand_m.copy(),
            receiver_pull_n=float(plant.pull_x),
        )
