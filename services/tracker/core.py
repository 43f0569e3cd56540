"""The tracker pipeline (pure: no bus, no files, no clocks of its own).

Inputs arrive with their local receive times (s, monotonic); the caller asks for the human
state after every skeleton frame and for the object estimate after depth frames:

    pipe = TrackerPipeline(config, arm_geometry)
    pipe.on_joint_state(q_rad, t_s)
    pipe.on_depth(depth_frame)                  # services.tracker.pointcloud.DepthFrame
    pipe.on_skeleton(skeleton_frame)            # SkeletonFrame
    state = pipe.human_state(now_s)             # HumanEstimate
    detection = pipe.detect_object()            # ObjectDetection or None (not due yet)
    pipe.set_object_wanted(object_wanted(...))  # full detection rate, or the rest rate

Object detection runs on every `object_every_n_depth_frames`-th depth frame while somebody
reads the object's position (the supervisor takes it in ``locate``, `object_wanted`), and on
every `object_rest_every_n_depth_frames`-th otherwise: a detection and its depth image are
most of the tracker's work, and the idle stack's largest single piece (issue 16).

Hand pipeline per skeleton frame: raw skeleton hand → (a) lag correction against the human's
point cloud of the latest depth frame (robot points removed) → (b) robot proximity hold.
Frames: the scene's `base` frame, metres.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from bus_schema.messages import SUPERVISOR_STATE_FRESH_S, Skeleton
from handover_model.robot_geometry import ArmGeometry
from handover_model.shapes import Capsule
from services.tracker.body import BodyDimensionEstimator, BodyDimensions
from services.tracker.config import TrackerConfig
from services.tracker.corrections import ProximityFilter, lag_correct, robot_point_mask
from services.tracker.lean import RowWindow, median_rows, vector_norm
from services.tracker.objects import ObjectDetection, detect_object
from services.tracker.pointcloud import DepthFrame, box_points

HAND_JOINT = "right_hand"
#: Skeleton joints around which depth points belong to the person (for object detection).
ARM_JOINTS = (("right_elbow", "right_hand"), ("left_elbow", "left_hand"))
PERSON_ARM_RADIUS_M = 0.12
#: Skeleton frames the reported torso position is the median of (0.5 s at 30 Hz).
TORSO_MEDIAN_FRAMES = 15


@dataclass(frozen=True)
class SkeletonFrame:
    """One skeleton from the tracker (`base`, metres).

    Attributes:
        tracked: a person is tracked.
        joints_m: joint name → (3,) position (may miss joints).
        t_s: local receive time (s).
    """

    tracked: bool
    joints_m: dict[str, np.ndarray]
    t_s: float


def skeleton_frame_from_message(msg: Skeleton, t_s: float) -> SkeletonFrame:
    """Convert a decoded `Skeleton` message received at `t_s`; the joints are read-only rows
    (3,) of one array (m, `base`)."""
    positions = np.array([j.position_m for j in msg.joints], dtype=float).reshape(-1, 3)
    positions.flags.writeable = False
    joints: dict[str, np.ndarray] = dict(zip([j.name for j in msg.joints], positions))
    return SkeletonFrame(tracked=bool(msg.tracked) and bool(joints), joints_m=joints, t_s=t_s)


@dataclass(frozen=True)
class HumanEstimate:
    """The tracker's receiver state (`base`, metres).

    Attributes:
        tracked: a person is tracked and the skeleton is fresh.
        hand_m, hand_raw_m: corrected and raw hand (3,).
        correction: which correction acted (the `HumanState.correction` values).
        torso_m: torso joint (3,).
        body: body dimensions.
        weight_kg: from the profile.
        frame_age_s: age of the skeleton frame (s).
        status: one line on the state (why not tracked, which inputs are missing).
    """

    tracked: bool
    hand_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    hand_raw_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    correction: str = "none"
    torso_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    body: BodyDimensions = field(default_factory=BodyDimensions)
    weight_kg: float = 0.0
    frame_age_s: float = 0.0
    status: str = ""


#: Supervisor phases in which it reads `perception/object` (it takes the object's position when
#: it locates it; later phases use that position, the planner only the mass).
OBJECT_PHASES = ("locate",)
# A supervisor state older than SUPERVISOR_STATE_FRESH_S no longer says the object is not
# wanted: a tracker without a supervisor (perception alone, a replay, a lost one) detects at full rate.


def object_wanted(phase: str | None, state_age_s: float) -> bool:
    """Whether the object's position is wanted now: no supervisor state heard (`phase` None),
    a state older than `SUPERVISOR_STATE_FRESH_S` (s), or a phase of `OBJECT_PHASES`."""
    return phase is None or state_age_s > SUPERVISOR_STATE_FRESH_S or phase in OBJECT_PHASES


class TrackerPipeline:
    """Skeleton + depth + joint state → corrected human state and object estimate.

    Args:
        config: tracker configuration.
        arm_geometry: the robot's arm capsules and forward kinematics.
    """

    def __init__(self, config: TrackerConfig, arm_geometry: ArmGeometry) -> None:
        self.config = config
        self.arm = arm_geometry
        self.body = BodyDimensionEstimator(config.floor_z_m, config.body_window_frames)
        self.proximity = ProximityFilter(
            config.proximity_engage_m, config.proximity_release_m, config.proximity_mode, config.predict_time_constant_s
        )
        self._skeleton: SkeletonFrame | None = None
        self._depth: DepthFrame | None = None
        self._depth_count = 0
        self._object_due = False
        #: Depth frames between two detections now (`set_object_wanted`).
        self._object_every_n = config.object_every_n_depth_frames
        #: The depth frame (count) at which a detection last fell due (None: none yet).
        self._object_due_frame: int | None = None
        self._q: np.ndarray | None = None
        self._q_t = 0.0
        self._robot_caps: list[Capsule] | None = None
        self._tool: np.ndarray | None = None
        self._last: HumanEstimate | None = None
        self._lost = True
        self._raw_history: deque[tuple[float, np.ndarray]] = deque(maxlen=64)
        #: Recent torso joints: the reported torso is their median (Kinect joints jitter by
        #: 5–10 cm; a standing receiver's torso should not look like a receiver who moved).
        self._torso_history = RowWindow(TORSO_MEDIAN_FRAMES, 3)

    # ------------------------------------------------------------------ inputs
    def on_joint_state(self, q_rad: np.ndarray, t_s: float) -> None:
        """Latest right-arm joints (7,), rad, received at `t_s`."""
        q = np.asarray(q_rad, float)
        if self._q is None or not np.array_equal(q, self._q):  # a still arm keeps its capsules
            self._robot_caps = None
            self._tool = None
        self._q = q
        self._q_t = t_s

    def on_depth(self, frame: DepthFrame) -> None:
        """Latest depth frame."""
        self._depth = frame
        self._depth_count += 1
        last = self._object_due_frame
        if last is None or self._depth_count - last >= self._object_every_n:
            self._object_due = True
            self._object_due_frame = self._depth_count

    def set_object_wanted(self, wanted: bool) -> None:
        """Detect on every `object_every_n_depth_frames`-th depth frame when `wanted`, else on
        every `object_rest_every_n_depth_frames`-th (never more often); counted from the last detection that fell
        due, so a switch to the full rate detects on the next frame when that one is due."""
        full_n = self.config.object_every_n_depth_frames
        self._object_every_n = full_n if wanted else max(full_n, self.config.object_rest_every_n_depth_frames)

    def on_skeleton(self, frame: SkeletonFrame) -> HumanEstimate:
        """Process a skeleton frame; returns the new human state."""
        self._skeleton = frame
        self._last = self._process(frame)
        return self._last

    # ------------------------------------------------------------------ helpers
    def _robot(self, now_s: float) -> tuple[list[Capsule] | None, np.ndarray | None]:
        if self._q is None or now_s - self._q_t > self.config.joint_state_timeout_s:
            return None, None
        if self._robot_caps is None:
            caps = self.arm.capsules(self._q)
            self._tool = self.arm.tool_position(self._q)
            if self.config.gripper_clearance_radius_m > 0.0:
                caps.append(Capsule(self._tool, self._tool, self.config.gripper_clearance_radius_m))
            self._robot_caps = caps
        return self._robot_caps, self._tool

    def _human_points_near(self, centre_m: np.ndarray, half_m: float, now_s: float) -> np.ndarray:
        """Points (N, 3) of the latest depth frame in the cube around `centre_m`, robot
        removed: only the image window the cube projects into is back-projected."""
        assert self._depth is not None
        pts = box_points(self._depth, centre_m, half_m).astype(float)
        if len(pts) == 0:
            return pts
        caps, _ = self._robot(now_s)
        if self.config.remove_robot_points and caps is not None:
            pts = pts[~robot_point_mask(pts, caps, self.config.robot_point_margin_m)]
        return pts

    # ------------------------------------------------------------------ hand
    def _process(self, frame: SkeletonFrame) -> HumanEstimate:
        cfg = self.config
        if not frame.tracked:
            self._lose()
            return HumanEstimate(tracked=False, weight_kg=cfg.weight_kg, body=self.body.estimate(),
                                 status="no person tracked")
        if HAND_JOINT not in frame.joints_m:
            self._lose()
            return HumanEstimate(tracked=False, weight_kg=cfg.weight_kg, body=self.body.estimate(),
                                 status="skeleton has no right_hand joint")
        self._lost = False
        now = frame.t_s
        raw = frame.joints_m[HAND_JOINT]
        hand = raw.copy()
        notes = []
        lag_acted = False
        speed = self._raw_speed(now, raw)
        if cfg.lag_correction and speed >= cfg.lag_min_speed_m_s:
            if self._depth is None or abs(now - self._depth.t_s) > cfg.depth_max_age_s:
                notes.append("no fresh depth: lag correction skipped")
            else:
                pts = self._human_points_near(raw, cfg.lag_box_half_size_m, now)
                _, tool = self._robot(now)
                reference = (tool if cfg.lag_reference == "robot_hand" and tool is not None
                             else self._depth.camera_position_m)
                res = lag_correct(
                    raw, pts, reference, cfg.lag_box_half_size_m, cfg.lag_snap_radius_m, cfg.lag_surface_offset_m
                )
                hand, lag_acted = res.position_m, res.acted
        held = False
        if cfg.proximity_filter:
            _, tool = self._robot(now)
            if tool is None:
                notes.append("no fresh joint state: proximity filter blind")
            hand, held = self.proximity.update(now, hand, tool)
        correction = {(False, False): "none", (True, False): "lag", (False, True): "proximity_hold",
                      (True, True): "lag+proximity_hold"}[(lag_acted, held)]
        self.body.update(frame.joints_m)
        torso = self._torso_m(frame)
        return HumanEstimate(
            tracked=True,
            hand_m=np.asarray(hand, float),
            hand_raw_m=raw.copy(),
            correction=correction,
            torso_m=np.asarray(torso, float),
            body=self.body.estimate(),
            weight_kg=cfg.weight_kg,
            status="; ".join(notes),
        )

    def _torso_m(self, frame: SkeletonFrame) -> np.ndarray:
        """The torso to report (3,), `base`: the median of the recent torso joints."""
        if "torso" in frame.joints_m:
            self._torso_history.append(np.asarray(frame.joints_m["torso"], float))
        return median_rows(self._torso_history.rows()) if len(self._torso_history) else np.zeros(3)

    def _raw_speed(self, now: float, raw: np.ndarray) -> float:
        """Speed (m/s) of the raw hand estimate over the last `lag_speed_window_s`."""
        hist = self._raw_history
        hist.append((now, raw.copy()))
        while len(hist) > 2 and hist[1][0] <= now - self.config.lag_speed_window_s:
            hist.popleft()
        t0, p0 = hist[0]
        if now - t0 < 0.5 * self.config.lag_speed_window_s:
            return 0.0
        return vector_norm(raw - p0) / (now - t0)

    def new_person(self) -> None:
        """Another person became the receiver (a camera that sees several): forget the
        previous one's torso, hand speed, proximity hold and body dimensions."""
        self._lose()
        self.body.reset()

    def _lose(self) -> None:
        self._raw_history.clear()
        self._torso_history.clear()
        self.proximity.reset()
        self._lost = True

    def human_state(self, now_s: float) -> HumanEstimate:
        """The state to publish at `now_s`: the last one, aged, or not tracked when stale."""
        cfg = self.config
        if self._last is None or self._skeleton is None:
            return HumanEstimate(tracked=False, weight_kg=cfg.weight_kg, status="no skeleton received yet")
        age = max(0.0, now_s - self._skeleton.t_s)
        if age > cfg.skeleton_timeout_s:
            if not self._lost:
                self._lose()
            return HumanEstimate(
                tracked=False, weight_kg=cfg.weight_kg, body=self.body.estimate(), frame_age_s=age,
                status=f"skeleton stale for {age:.2f} s",
            )
        last = self._last
        return HumanEstimate(
            tracked=last.tracked, hand_m=last.hand_m, hand_raw_m=last.hand_raw_m, correction=last.correction,
            torso_m=last.torso_m, body=last.body, weight_kg=last.weight_kg, frame_age_s=age, status=last.status,
        )

    # ------------------------------------------------------------------ object
    def detect_object(self, force: bool = False) -> ObjectDetection | None:
        """Detect the object on the latest depth frame when due (every n-th frame) or when
        `force`d; None when not due or no depth yet."""
        if self._depth is None or not (self._object_due or force):
            return None
        self._object_due = False
        cfg = self.config
        return detect_object(
            self._depth, cfg.floor_z_m, self._excluded_points, cfg.object_min_height_m, cfg.object_max_height_m,
            cfg.object_min_pixels,
        )

    def _excluded_points(self, pts: np.ndarray) -> np.ndarray:
        """Mask (N,) of points (N, 3) on the robot (its capsules) or the person's forearms."""
        assert self._depth is not None  # called by detect_object, on the latest depth frame
        caps: list[Capsule] = []
        robot_caps, _ = self._robot(self._depth.t_s)
        if robot_caps is not None:
            caps.extend(robot_caps)
        if self._skeleton is not None and self._skeleton.tracked:
            j = self._skeleton.joints_m
            for a, b in ARM_JOINTS:
                if a in j and b in j:
                    caps.append(Capsule(j[a], j[b], PERSON_ARM_RADIUS_M))
        return robot_point_mask(pts, caps, self.config.robot_point_margin_m)
