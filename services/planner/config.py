"""Typed, validated configuration of the planner (``[services.planner.config]`` in a profile).

Example (every key optional; the values shown are the defaults)::

    [services.planner.config]
    object_mass_kg = 0.065            # used until the tracker reports a mass > 0
    object_spill_sensitive = false    # a full cup: slower reach (§2.4.2)

    [services.planner.config.giver]   # the robot modelled as a human (§2.5)
    height_m = 1.90
    arm_span_m = 2.00
    weight_kg = 100.0
    posture = "standing"
    is_robot = true                   # robot: its shoulder stays where it is (no lean)
    shoulder_x_task_m = -0.5          # the robot's shoulder (its stand-in's), task plane x

    [services.planner.config.receiver_default]   # used for what the tracker does not report
    height_m = 1.75
    arm_span_m = 1.75
    weight_kg = 75.0
    posture = "standing"
    seat_height_m = 0.45

    [services.planner.config.model]
    grid_resolution_m = 0.01
    min_height_above_table_m = 0.0
    max_reach_fraction = 1.0
    object_load = "giver"             # eq 2.3; giver | receiver | both | none
    lean_fraction_of_height = 0.04    # human shoulders this far toward the partner
    max_upper_arm_elevation_deg = 90.0  # upper arm at most horizontal (180: the uncapped model)
    grasp_fraction_of_hand = 0.5
    use_measured_shoulder_height = true
    table_height_m = 0.70

    [services.planner.config.frame]   # task plane in the scene's base frame
    origin_base_m = [0.564, -0.259, -0.23]
    x_axis_base_xy = [1.0, 0.0]

    [services.planner.config.timing]
    normalised_peak_velocity_1_s = 1.6
    spill_sensitive_normalised_peak_velocity_1_s = 1.0
    max_peak_speed_m_s = 1.0
    reach_start_base_m = [0.72, -0.55, -0.07]

    [services.planner.config.replan]
    receiver_move_threshold_m = 0.05
    dimension_threshold_m = 0.02
    weight_threshold_kg = 2.0
    mass_threshold_kg = 0.005
    republish_period_s = 1.0
"""

from __future__ import annotations

from typing import Any, Literal

import msgspec
import numpy as np

from handover_model import scene
from handover_model.robots import RobotDescription
from handover_model.body import MAX_LEAN_FRACTION
from services.planner.anthropometrics import BodyDimensions
from services.planner.djt.settings import DJTSettings
from services.planner.errors import PlannerError
from services.planner.frames import DEFAULT_ORIGIN_BASE_M, TaskPlaneFrame
from services.planner.reach_timing import (
    DEFAULT_NORMALISED_PEAK_VELOCITY_1_S,
    DEFAULT_SPILL_SENSITIVE_NORMALISED_PEAK_VELOCITY_1_S,
)

#: Where the hand starts the reach by default: above the object's pick position (base, m).
DEFAULT_REACH_START_BASE_M = (
    float(scene.OBJECT_PICK_BASE_M[0]),
    float(scene.OBJECT_PICK_BASE_M[1]),
    float(scene.OBJECT_PICK_BASE_M[2]) + 0.10,
)


class _Cfg(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    pass


class GiverConfig(_Cfg, frozen=True, kw_only=True):
    """The giver's body and place (default: the robot's stand-in, `handover_model.robots.GiverStandIn`)."""

    height_m: float = 1.90
    arm_span_m: float = 2.00
    weight_kg: float = 100.0
    posture: Literal["standing", "sitting"] = "standing"
    seat_height_m: float = 0.45
    is_robot: bool = True
    shoulder_x_task_m: float = -scene.ACTOR_SEPARATION_M / 2.0

    def body(self) -> BodyDimensions:
        return BodyDimensions(
            self.height_m, self.arm_span_m, self.weight_kg, self.posture, self.seat_height_m
        )


class ReceiverDefaults(_Cfg, frozen=True, kw_only=True):
    """Receiver values used where the tracker reports none (0 or ``unknown``)."""

    height_m: float = 1.75
    arm_span_m: float = 1.75
    weight_kg: float = 75.0
    posture: Literal["standing", "sitting"] = "standing"
    seat_height_m: float = 0.45


class ModelConfig(_Cfg, frozen=True, kw_only=True):
    """DJT model choices (see `djt.DJTSettings` and `core.DyadGeometry`)."""

    grid_resolution_m: float = 0.01
    refine: bool = True
    min_height_above_table_m: float = 0.0
    max_reach_fraction: float = 1.0
    object_load: Literal["giver", "receiver", "both", "none"] = "giver"
    lean_fraction_of_height: float = MAX_LEAN_FRACTION
    #: Highest upper-arm elevation from hanging an actor takes an object with, deg (90 =
    #: upper arm horizontal; 180 = the thesis's model, capped only by the arm straight up).
    #: Both modelled arms, the robot giver's included. See `djt.UPPER_ARM_MAX_ANGLE_RAD`.
    max_upper_arm_elevation_deg: float = 90.0
    grasp_fraction_of_hand: float = 0.5
    use_measured_shoulder_height: bool = True
    table_height_m: float = scene.TABLE_HEIGHT_M

    def djt_settings(self) -> DJTSettings:
        lo, _ = DJTSettings().shoulder_angle_range_rad
        return DJTSettings(
            min_height_above_table_m=self.min_height_above_table_m,
            max_reach_fraction=self.max_reach_fraction,
            shoulder_angle_range_rad=(lo, float(np.deg2rad(self.max_upper_arm_elevation_deg - 90.0))),
            object_load=self.object_load,
            grid_resolution_m=self.grid_resolution_m,
            refine=self.refine,
        )


class FrameConfig(_Cfg, frozen=True, kw_only=True):
    """Task plane in the scene's `base` frame (see `frames.TaskPlaneFrame`)."""

    origin_base_m: tuple[float, float, float] = DEFAULT_ORIGIN_BASE_M
    x_axis_base_xy: tuple[float, float] = (1.0, 0.0)

    def frame(self) -> TaskPlaneFrame:
        return TaskPlaneFrame(self.origin_base_m, self.x_axis_base_xy)


class TimingConfig(_Cfg, frozen=True, kw_only=True):
    """Reach timing (§2.4.2)."""

    normalised_peak_velocity_1_s: float = DEFAULT_NORMALISED_PEAK_VELOCITY_1_S
    spill_sensitive_normalised_peak_velocity_1_s: float = (
        DEFAULT_SPILL_SENSITIVE_NORMALISED_PEAK_VELOCITY_1_S
    )
    max_peak_speed_m_s: float = 1.0
    reach_start_base_m: tuple[float, float, float] = DEFAULT_REACH_START_BASE_M


class ReplanConfig(_Cfg, frozen=True, kw_only=True):
    """When a new plan is made, and how often the last one is repeated."""

    receiver_move_threshold_m: float = 0.05
    dimension_threshold_m: float = 0.02
    weight_threshold_kg: float = 2.0
    mass_threshold_kg: float = 0.005
    republish_period_s: float = 1.0


class PlannerConfig(_Cfg, frozen=True, kw_only=True):
    """The planner service's whole configuration."""

    object_mass_kg: float = 0.065
    object_spill_sensitive: bool = False
    giver: GiverConfig = GiverConfig()
    receiver_default: ReceiverDefaults = ReceiverDefaults()
    model: ModelConfig = ModelConfig()
    frame: FrameConfig = FrameConfig()
    timing: TimingConfig = TimingConfig()
    replan: ReplanConfig = ReplanConfig()


def _positive(name: str, value: float) -> None:
    if not (np.isfinite(value) and value > 0.0):
        raise PlannerError(f"planner config: {name} = {value!r} must be a positive number")


def validate(cfg: PlannerConfig) -> PlannerConfig:
    """Check every value (building the typed objects validates bodies and model choices).

    Raises:
        PlannerError: naming the key to fix.
    """
    if not (0.0 <= cfg.object_mass_kg <= 50.0):
        raise PlannerError(f"planner config: object_mass_kg = {cfg.object_mass_kg!r} must be 0..50 kg")
    try:
        cfg.giver.body()
    except PlannerError as exc:
        raise PlannerError(f"planner config [giver]: {exc}") from None
    d = cfg.receiver_default
    try:
        BodyDimensions(d.height_m, d.arm_span_m, d.weight_kg, d.posture, d.seat_height_m)
    except PlannerError as exc:
        raise PlannerError(f"planner config [receiver_default]: {exc}") from None
    if not (45.0 <= cfg.model.max_upper_arm_elevation_deg <= 180.0):
        raise PlannerError(
            "planner config: model.max_upper_arm_elevation_deg must be within 45..180 deg "
            "(90: upper arm horizontal)"
        )
    try:
        cfg.model.djt_settings()
        cfg.frame.frame()
    except PlannerError as exc:
        raise PlannerError(f"planner config: {exc}") from None
    if not (0.0 <= cfg.model.lean_fraction_of_height <= 0.2):
        raise PlannerError("planner config: model.lean_fraction_of_height must be within 0..0.2")
    if not (0.0 <= cfg.model.grasp_fraction_of_hand <= 1.0):
        raise PlannerError("planner config: model.grasp_fraction_of_hand must be within 0..1")
    if not (0.3 <= cfg.model.table_height_m <= 1.5):
        raise PlannerError("planner config: model.table_height_m must be within 0.3..1.5 m")
    t = cfg.timing
    _positive("timing.normalised_peak_velocity_1_s", t.normalised_peak_velocity_1_s)
    _positive(
        "timing.spill_sensitive_normalised_peak_velocity_1_s",
        t.spill_sensitive_normalised_peak_velocity_1_s,
    )
    _positive("timing.max_peak_speed_m_s", t.max_peak_speed_m_s)
    if not all(np.isfinite(t.reach_start_base_m)):
        raise PlannerError("planner config: timing.reach_start_base_m must be 3 finite numbers")
    r = cfg.replan
    _positive("replan.receiver_move_threshold_m", r.receiver_move_threshold_m)
    _positive("replan.dimension_threshold_m", r.dimension_threshold_m)
    _positive("replan.weight_threshold_kg", r.weight_threshold_kg)
    _positive("replan.mass_threshold_kg", r.mass_threshold_kg)
    _positive("replan.republish_period_s", r.republish_period_s)
    return cfg


def robot_defaults(table: dict[str, Any], robot: RobotDescription) -> dict[str, Any]:
    """`table` with what the robot's description says filled in where the table is silent: the
    giver's stand-in (`[giver]`) and where the reach starts (above the object's pick place)."""
    table = dict(table)
    g = robot.giver
    stand_in = {"height_m": g.height_m, "arm_span_m": g.arm_span_m, "weight_kg": g.weight_kg,
                "shoulder_x_task_m": g.shoulder_x_task_m, "posture": g.posture, "seat_height_m": g.seat_height_m}
    giver = table.get("giver", {})
    table["giver"] = {**stand_in, **giver} if isinstance(giver, dict) else giver
    timing = table.get("timing", {})
    if isinstance(timing, dict) and "reach_start_base_m" not in timing:
        x, y, z = robot.object_pick_base_m
        table["timing"] = {**timing, "reach_start_base_m": [x, y, z + 0.10]}
    return table


def load_config(table: dict[str, Any] | None, robot: RobotDescription | None = None) -> PlannerConfig:
    """The typed config from a profile's ``[services.planner.config]`` table ({} → defaults);
    with `robot`, the giver's stand-in and the reach start default to the robot's.

    Raises:
        PlannerError: unknown key, wrong type or invalid value, naming the key.
    """
    table = robot_defaults(table or {}, robot) if robot is not None else (table or {})
    try:
        cfg = msgspec.convert(table, PlannerConfig)
    except msgspec.ValidationError as exc:
        raise PlannerError(f"planner config: {exc}") from None
    return validate(cfg)
