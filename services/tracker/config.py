"""Typed, validated tracker configuration (SI units).

Read from ``[services.tracker.config]`` of the deploy profile and overridden by the CLI.
"""

from __future__ import annotations

from typing import Literal

import msgspec

from handover_model import scene
from services.sim_kinect.config import KinectConfig
from services.tracker.camera.config import CameraConfig
from services.tracker.errors import TrackerConfigError
from services.tracker.ros1.config import Ros1KinectConfig


class TrackerConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Tracker settings.

    The correction defaults follow `handover-study tracker-defaults` (docs/tracker.md#defaults):
    (a) only above 0.7 m/s and (b) off were best on seeds 0–15 and again on seeds 1000–1015;
    (b) on doubled the median hand error.

    Attributes:
        lag_correction: apply Mincelli's lag correction (a).
        lag_reference: "closest" is measured from the ``sensor`` (Mincelli et al.'s Kinect
            faced the receiver at hand height) or from the ``robot_hand`` the receiver reaches
            for (better for a sensor above the robot; falls back to the sensor when the
            joint state is stale).
        lag_min_speed_m_s: apply (a) only while the raw hand estimate moves faster than this,
            measured over `lag_speed_window_s` (the lag only matters while the hand moves;
            0 applies it on every frame).
        lag_speed_window_s: window of that speed (s), long enough to average out jitter.
        lag_box_half_size_m: half edge of the cube around the hand estimate searched for
            the human's closest point.
        lag_snap_radius_m: average the cloud points within this radius of the closest point
            (0: take the single closest point, exactly as Mincelli et al.).
        lag_surface_offset_m: push the snapped surface point away from the sensor by this
            much, from the hand's visible surface toward its centre.
        proximity_filter: apply Mincelli's robot-proximity filter (b).
        proximity_engage_m: the filter engages when the robot's hand is closer than this to
            the human's hand estimate (Mincelli et al.: 15 cm).
        proximity_release_m: and releases when farther than this (hysteresis).
        proximity_mode: ``hold`` the last estimate, or ``predict`` it with the velocity it had,
            decaying with `predict_time_constant_s`.
        predict_time_constant_s: velocity decay of ``predict`` (s).
        remove_robot_points: remove points inside the robot's link capsules from the cloud.
        robot_point_margin_m: inflate the robot's capsules by this much for the removal.
        gripper_clearance_radius_m: also remove points within this radius of the tool frame
            (the fingers and a held object).
        skeleton_timeout_s: a skeleton older than this (local receive time) means not tracked.
        depth_max_age_s: depth older than this (relative to the skeleton) is not used.
        joint_state_timeout_s: joint state older than this is not used for (b).
        body_window_frames: body dimensions are medians over this many recent frames.
        weight_kg: receiver's body weight from the profile (a camera cannot weigh).
        object_mass_kg: object mass from the task description.
        object_every_n_depth_frames: run object detection on every n-th depth frame while
            the object's position is wanted (the supervisor locating it, or no supervisor
            heard: `services.tracker.core.object_wanted`).
        object_rest_every_n_depth_frames: the same while the supervisor says nobody reads it
            (outside an episode, or the object already picked): 15 (2 Hz at 30 Hz) keeps the
            newest estimate within the supervisor's 1 s freshness for the next locate; never
            more often than `object_every_n_depth_frames` (the larger of the two is used).
        object_min_height_m, object_max_height_m: object points lie this high above the table.
        object_min_pixels: smallest blob taken for an object.
        floor_z_m: floor height in `base` (m).
        rate_hz: the node's loop rate with ``sensor = "bus"`` (with ``"sim"`` the loop runs
            at the simulated Kinect's frame rate).
        sensor: where skeleton and depth come from: ``bus`` (`perception/skeleton` and
            `perception/depth`: a Kinect driver or the stand-alone simulated Kinect service),
            ``sim`` (the simulated Kinect rendered in the tracker's own process from
            `robot/joint_state` and `sim/truth`; `services.tracker.sources`) or ``ros1``
            (openni_tracker's ``/tf`` and a depth image as ROS 1 bytes through the Zenoh ROS 1
            bridge, `ros1`; `services.tracker.ros1.source`).
        sim_kinect: the simulated Kinect of ``sensor = "sim"`` (the fields of
            `services.sim_kinect.config.KinectConfig`: rate, receiver's body, scene, seed).
        publish_depth: with ``sensor = "sim"`` or ``"ros1"``, also publish `perception/depth`
            (a recorder with ``depth_every`` ≥ 1 records it; nothing else reads it).
        ros1: the ROS 1 Kinect of ``sensor = "ros1"`` (`Ros1KinectConfig`: topics, key
            mapping, the calibration file, the receiver's choice).
        camera: the camera of ``sensor = "camera"`` (`CameraConfig`: input, depth, intrinsics,
            calibration file, the receiver's choice, the object's place).
        sim_clock_latency_s: on the simulation clock (docs/sim_clock.md), the simulated time
            a frame's results take, s: what the tracker publishes for a frame taken at t is
            stamped t + this, and the rest of the stack steps on while it computes. 0: the
            clock waits for each frame's work (results stamped t). Less than a frame period.
    """

    lag_correction: bool = True
    lag_reference: Literal["sensor", "robot_hand"] = "robot_hand"
    lag_min_speed_m_s: float = 0.7
    lag_speed_window_s: float = 0.3
    lag_box_half_size_m: float = 0.12
    lag_snap_radius_m: float = 0.04
    lag_surface_offset_m: float = 0.03
    proximity_filter: bool = False
    proximity_engage_m: float = 0.15
    proximity_release_m: float = 0.17
    proximity_mode: Literal["hold", "predict"] = "hold"
    predict_time_constant_s: float = 0.15
    remove_robot_points: bool = True
    robot_point_margin_m: float = 0.03
    gripper_clearance_radius_m: float = 0.08
    skeleton_timeout_s: float = 0.5
    depth_max_age_s: float = 0.2
    joint_state_timeout_s: float = 0.5
    body_window_frames: int = 90
    weight_kg: float = 75.0
    object_mass_kg: float = 0.5
    object_every_n_depth_frames: int = 3
    object_rest_every_n_depth_frames: int = 15
    object_min_height_m: float = 0.02
    object_max_height_m: float = 0.40
    object_min_pixels: int = 20
    floor_z_m: float = -scene.BASE_HEIGHT_ABOVE_FLOOR_M
    rate_hz: float = 60.0
    sensor: Literal["bus", "sim", "ros1", "camera"] = "bus"
    sim_kinect: KinectConfig = msgspec.field(default_factory=KinectConfig)
    publish_depth: bool = False
    ros1: Ros1KinectConfig = msgspec.field(default_factory=Ros1KinectConfig)
    camera: CameraConfig = msgspec.field(default_factory=CameraConfig)
    sim_clock_latency_s: float = 0.03

    def __post_init__(self) -> None:
        checks = [
            (0.01 <= self.lag_box_half_size_m <= 0.5, "lag_box_half_size_m must be in 0.01..0.5 m"),
            (0.0 <= self.lag_min_speed_m_s <= 10.0, "lag_min_speed_m_s must be in 0..10 m/s"),
            (0.03 <= self.lag_speed_window_s <= 2.0, "lag_speed_window_s must be in 0.03..2 s"),
            (0.0 <= self.lag_snap_radius_m <= 0.2, "lag_snap_radius_m must be in 0..0.2 m"),
            (0.0 <= self.lag_surface_offset_m <= 0.1, "lag_surface_offset_m must be in 0..0.1 m"),
            (0.0 < self.proximity_engage_m <= 1.0, "proximity_engage_m must be in (0, 1] m"),
            (
                self.proximity_engage_m <= self.proximity_release_m <= 1.5,
                "proximity_release_m must be >= proximity_engage_m and <= 1.5 m",
            ),
            (self.predict_time_constant_s > 0.0, "predict_time_constant_s must be > 0"),
            (0.0 <= self.robot_point_margin_m <= 0.2, "robot_point_margin_m must be in 0..0.2 m"),
            (0.0 <= self.gripper_clearance_radius_m <= 0.3, "gripper_clearance_radius_m must be in 0..0.3 m"),
            (self.skeleton_timeout_s > 0.0, "skeleton_timeout_s must be > 0"),
            (0.0 <= self.sim_clock_latency_s < 1.0 / self.sim_kinect.rate_hz,
             "sim_clock_latency_s must be >= 0 and shorter than a frame of the simulated Kinect"),
            (self.depth_max_age_s > 0.0, "depth_max_age_s must be > 0"),
            (self.joint_state_timeout_s > 0.0, "joint_state_timeout_s must be > 0"),
            (1 <= self.body_window_frames <= 10000, "body_window_frames must be in 1..10000"),
            (0.0 <= self.weight_kg <= 400.0, "weight_kg must be in 0..400 kg"),
            (0.0 <= self.object_mass_kg <= 1000.0, "object_mass_kg must be in 0..1000 kg"),
            (1 <= self.object_every_n_depth_frames <= 1000, "object_every_n_depth_frames must be in 1..1000"),
            (1 <= self.object_rest_every_n_depth_frames <= 1000, "object_rest_every_n_depth_frames must be in 1..1000"),
            (
                0.0 <= self.object_min_height_m < self.object_max_height_m <= 2.0,
                "need 0 <= object_min_height_m < object_max_height_m <= 2 m",
            ),
            (self.object_min_pixels >= 1, "object_min_pixels must be >= 1"),
            (-5.0 <= self.floor_z_m <= 0.0, "floor_z_m must be in -5..0 m"),
            (0.0 < self.rate_hz <= 1000.0, "rate_hz must be in (0, 1000] Hz"),
        ]
        for ok, message in checks:
            if not ok:
                raise TrackerConfigError(f"invalid tracker config: {message}")
        if self.sensor == "ros1" and not self.ros1.calibration_file:
            raise TrackerConfigError("invalid tracker config: sensor = \"ros1\" needs ros1.calibration_file, the "
                                     "camera's pose in base (docs/kinect_ros1.md#calibration)")
        if self.sensor == "camera" and self.camera.problems():
            raise TrackerConfigError(f"invalid tracker config: {self.camera.problems()[0]}")
        if self.sim_kinect.hand_target_base_m and len(self.sim_kinect.hand_target_base_m) != 3:
            raise TrackerConfigError("invalid tracker config: sim_kinect.hand_target_base_m needs 3 values (x, y, z)")


def config_from_dict(values: dict) -> TrackerConfig:
    """Build a `TrackerConfig` from a profile/CLI dict, with a one-line error on bad input.

    Raises:
        TrackerConfigError: unknown key, wrong type or out-of-range value.
    """
    try:
        return msgspec.convert(values, TrackerConfig)
    except TrackerConfigError:
        raise
    except msgspec.ValidationError as exc:
        raise TrackerConfigError(f"invalid tracker config: {exc}") from None
