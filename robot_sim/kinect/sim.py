"""The simulated Kinect: a receiver, the table, the object and the robot's arm, seen in depth,
plus the skeleton a real tracker would report.

Use::

    sim = KinectSim(seed=3, scenario=KinectScenario(posture="sitting"))
    frame = sim.step(t_s, q_arm_rad)                     # 30 Hz
    skeleton_pub.put(**frame.skeleton_fields)            # bus_schema.messages.Skeleton
    depth_pub.put(**frame.depth_fields)                  # bus_schema.messages.DepthImage
    frame.readings.metres()                              # the depth in metres, no bytes
    frame.truth.right_hand_m                             # ground truth (for SimTruth)

Depth cost: a frame's depth is made only when something reads it
(`robot_sim.kinect.readings`). The static scene (floor, table, the robot's fixed parts, the
receiver's legs) is cast once; a render casts only the primitives that moved since the
previous render and reuses the image when nothing moved (`robot_sim.kinect.scene_depth`),
and quantises into kept buffers (`robot_sim.kinect.quantise`). The images equal those of the
full ray cast (`KinectSim.reference_depth_m` with `kinect_depth_mm` and the frame's
`KinectSim.noise_rng`) bit for bit, noise included.

Frames: everything in the scene's `base` (x forward, y left, z up), metres; the camera's pose
and intrinsics are in `robot_sim.kinect.camera`, the table and the receiver's placement in
`handover_model.scene`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from bus_schema.messages import SKELETON_JOINTS, SkeletonJoint
from handover_model import robots, scene
from robot_sim.kinect.camera import KinectCamera
from robot_sim.kinect.quantise import DepthQuantiser
from robot_sim.kinect.readings import DepthReadings
from robot_sim.kinect.receiver import BodySize, ReceiverBody, min_jerk
from handover_model.robot_geometry import ArmGeometry
from robot_sim.kinect.scene_depth import SceneDepthRenderer, StaticScene, render_reference
from handover_model.shapes import Box, Capsule
from robot_sim.kinect.skeleton_model import SkeletonErrorModel, SkeletonErrorParams

TABLE_THICKNESS_M = 0.03
TABLE_LEG_RADIUS_M = 0.025
#: Default object: a 6 x 6 x 12 cm box (x, y, z), as the bottle-sized objects of the thesis.
DEFAULT_OBJECT_SIZE_M = (0.06, 0.06, 0.12)
#: The second word of every depth noise seed (`KinectSim.noise_rng`): (seed, stream, frame).
DEPTH_NOISE_STREAM = 1


def table_boxes_and_legs() -> tuple[Box, list[Capsule]]:
    """The table top (a box) and its four legs (capsules) from `handover_model.scene`."""
    c = scene.TABLE_TOP_CENTRE_BASE_M
    half = np.array([scene.TABLE_DEPTH_M / 2.0, scene.TABLE_WIDTH_M / 2.0])
    top = Box(
        np.array([c[0] - half[0], c[1] - half[1], c[2] - TABLE_THICKNESS_M]),
        np.array([c[0] + half[0], c[1] + half[1], c[2]]),
    )
    floor_z = -scene.BASE_HEIGHT_ABOVE_FLOOR_M
    legs = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            x = c[0] + sx * (half[0] - 0.04)
            y = c[1] + sy * (half[1] - 0.04)
            legs.append(Capsule(np.array([x, y, floor_z]), np.array([x, y, c[2] - TABLE_THICKNESS_M]),
                                TABLE_LEG_RADIUS_M))
    return top, legs


def object_box(centre_m: np.ndarray, size_m: tuple[float, float, float]) -> Box:
    """Axis-aligned box of the object centred at `centre_m` (m, `base`)."""
    half = np.asarray(size_m, float) / 2.0
    centre = np.asarray(centre_m, float)
    return Box(centre - half, centre + half)


@dataclass(frozen=True)
class KinectScenario:
    """What the simulated Kinect sees (SI units, `base` frame).

    Attributes:
        height_m, posture: the receiver's body.
        hand_target_base_m: where the receiver's right hand reaches to (None: it stays at
            rest until `KinectSim.set_hand_target` is called).
        reach_start_s, reach_duration_s: minimum-jerk reach timing.
        object_size_m: the object's box extents (x, y, z).
        skeleton_errors: the skeleton tracker's error model.
        depth_dropout_fraction: fraction of depth pixels with no reading.
        depth_noise: add Kinect depth noise (False: quantisation only).
    """

    height_m: float = 1.75
    posture: Literal["standing", "sitting"] = "standing"
    hand_target_base_m: tuple[float, float, float] | None = None
    reach_start_s: float = 0.5
    reach_duration_s: float = 1.5
    object_size_m: tuple[float, float, float] = DEFAULT_OBJECT_SIZE_M
    skeleton_errors: SkeletonErrorParams = field(default_factory=SkeletonErrorParams)
    depth_dropout_fraction: float = 0.005
    depth_noise: bool = True

    def __post_init__(self) -> None:
        if not 1.2 <= self.height_m <= 2.2:
            raise ValueError(f"receiver height {self.height_m} m outside 1.2–2.2 m")
        if self.posture not in ("standing", "sitting"):
            raise ValueError(f"posture must be standing or sitting, not {self.posture!r}")
        if self.reach_duration_s <= 0.0:
            raise ValueError("reach_duration_s must be > 0")


@dataclass(frozen=True)
class KinectTruth:
    """Ground truth of one frame (m, `base`)."""

    t_s: float
    joints_m: dict[str, np.ndarray]
    right_hand_m: np.ndarray
    robot_tool_m: np.ndarray
    object_position_m: np.ndarray
    object_size_m: tuple[float, float, float]
    body: BodySize


@dataclass(frozen=True)
class KinectFrame:
    """One 30 Hz output of the simulated Kinect.

    Attributes:
        skeleton_fields: keyword fields of `bus_schema.messages.Skeleton` (no header).
        camera_fields: the `bus_schema.messages.DepthImage` fields of the camera (size,
            intrinsics, pose): all but the header and the readings.
        readings: the depth readings, made at their first read.
        truth: ground truth.
    """

    skeleton_fields: dict[str, Any]
    camera_fields: dict[str, Any]
    readings: DepthReadings
    truth: KinectTruth

    @property
    def depth_fields(self) -> dict[str, Any]:
        """Keyword fields of `bus_schema.messages.DepthImage` (no header); makes the readings."""
        return {**self.camera_fields, "depth_mm": self.readings.payload}

    @property
    def depth_mm(self) -> np.ndarray:
        """The depth image (H, W) uint16 mm (0 = no reading): a read-only view of the bytes of
        `depth_fields["depth_mm"]`; makes the readings."""
        return self.readings.mm


class KinectSim:
    """Seeded simulated Kinect (depth + skeleton) of the handover scene.

    Args:
        seed: random seed (skeleton errors; each frame's depth noise, `noise_rng`).
        scenario: what is in the scene.
        camera: sensor pose and intrinsics (default: `robot_sim.kinect.camera`).
        arm_geometry: the robot's arm capsules (default: the active arm's).
    """

    def __init__(
        self,
        seed: int = 0,
        scenario: KinectScenario | None = None,
        camera: KinectCamera | None = None,
        arm_geometry: ArmGeometry | None = None,
    ) -> None:
        self.scenario = scenario or KinectScenario()
        self.camera = camera or KinectCamera()
        self.arm = arm_geometry or ArmGeometry()
        self.seed = seed
        self.rng = np.random.default_rng(seed)  # the skeleton's errors
        self.frames = 0  # frames stepped so far: the next frame's index
        self.body = ReceiverBody(BodySize(self.scenario.height_m, self.scenario.posture))
        self.errors = SkeletonErrorModel(self.scenario.skeleton_errors, self.rng)
        self._table_top, self._table_legs = table_boxes_and_legs()
        #: What never moves (floor, table, the robot's fixed parts, the receiver's legs): cast once.
        self.static_scene = StaticScene(
            capsules=(*self._table_legs, *self.arm.body_capsules, *self.body.static_capsules()),
            boxes=(self._table_top,), floor_z_m=-scene.BASE_HEIGHT_ABOVE_FLOOR_M)
        self.depth = SceneDepthRenderer(self.camera, self.static_scene)
        self.renderer = self.depth.renderer
        dropout = self.scenario.depth_dropout_fraction if self.scenario.depth_noise else 0.0
        self._quantiser = DepthQuantiser((self.camera.height_px, self.camera.width_px), dropout)
        c = self.camera
        #: The DepthImage fields that do not change (the camera does not move).
        self.camera_fields = {
            "width": c.width_px, "height": c.height_px, "fx": c.fx_px, "fy": c.fy_px, "cx": c.cx_px,
            "cy": c.cy_px, "camera_position_m": tuple(float(v) for v in c.position_m),
            "camera_orientation_xyzw": c.orientation_xyzw,
        }
        self._hand_start = self.body.rest_hand_m
        target = self.scenario.hand_target_base_m
        self._hand_target = None if target is None else np.asarray(target, float)
        self._reach_start_s = self.scenario.reach_start_s
        self._reach_duration_s = self.scenario.reach_duration_s
        self._last_hand = self._hand_start.copy()
        #: The body's joints (read-only arrays) and their stacked rows for the hand position
        #: of these bytes, and the tool position for the arm's joints of those bytes: a still
        #: receiver and a still arm (every idle frame) are not solved again.
        self._joints_for: tuple[bytes, dict[str, np.ndarray], np.ndarray] | None = None
        self._tool_for: tuple[bytes, np.ndarray] | None = None

    def set_hand_target(self, target_base_m: np.ndarray | None, start_s: float, duration_s: float) -> None:
        """Start a minimum-jerk reach of the right hand from where it is now to `target_base_m`
        (None: back to rest), beginning at `start_s` and lasting `duration_s` seconds."""
        if duration_s <= 0.0:
            raise ValueError("duration_s must be > 0")
        self._hand_start = self._last_hand.copy()
        self._hand_target = self.body.rest_hand_m if target_base_m is None else np.asarray(target_base_m, float)
        self._reach_start_s = float(start_s)
        self._reach_duration_s = float(duration_s)

    def true_hand(self, t_s: float) -> np.ndarray:
        """Commanded true right-hand position at `t_s` (before the arm's reach limit)."""
        if self._hand_target is None:
            return self._hand_start.copy()
        s = min_jerk((t_s - self._reach_start_s) / self._reach_duration_s)
        return self._hand_start + s * (self._hand_target - self._hand_start)

    def moving_shapes(self, joints: dict[str, np.ndarray], q_arm_rad: np.ndarray,
                      object_position_m: np.ndarray) -> tuple[list[Capsule], list[Box]]:
        """The primitives that can move (m, `base`): the receiver's head, trunk and arms for
        `joints`, the arm's links at `q_arm_rad` (rad) and the object's box at
        `object_position_m`; the rest of the scene is `static_scene`."""
        capsules = self.body.moving_capsules(joints) + self.arm.capsules(q_arm_rad, include_torso=False)
        return capsules, [object_box(object_position_m, self.scenario.object_size_m)]

    def reference_depth_m(self, joints: dict[str, np.ndarray], q_arm_rad: np.ndarray,
                          object_position_m: np.ndarray) -> np.ndarray:
        """Ideal depth (H, W), m, of the same scene as `moving_shapes`, cast whole without any
        cache (`render_reference`): what `step` renders, for tests and benchmarks."""
        return render_reference(self.renderer, self.static_scene, *self.moving_shapes(joints, q_arm_rad,
                                                                                       object_position_m))

    def step(
        self,
        t_s: float,
        q_arm_rad: np.ndarray,
        object_position_m: np.ndarray | None = None,
        right_hand_m: np.ndarray | None = None,
    ) -> KinectFrame:
        """Render the frame at time `t_s` (s, increasing).

        Args:
            q_arm_rad: the arm's joints (n,), rad.
            object_position_m: object centre (m, `base`); default: waiting on the table at
                the active arm's `object_pick_base_m`.
            right_hand_m: where the receiver's right hand is (m, `base`), when another model
                (the handover scene) drives it; default: this simulator's own reach.
        """
        hand = self.true_hand(t_s) if right_hand_m is None else np.asarray(right_hand_m, float)
        joints, joints_arr = self._joints_at(hand)
        self._last_hand = joints["right_hand"].copy()
        q = np.array(q_arm_rad, float)  # copies: the frame's depth may be made later
        tool = self._tool_at(q)
        obj = np.array(robots.active().object_pick_base_m if object_position_m is None else object_position_m, float)
        index, self.frames = self.frames, self.frames + 1
        # The moving shapes too are made only when the depth is read.
        readings = DepthReadings(lambda: self._render(self.moving_shapes(joints, q, obj)), self._quantiser,
                                 (lambda: self.noise_rng(index)) if self.scenario.depth_noise else None)
        tracked, est, conf = self.errors.step(t_s, joints_arr, tool)
        skeleton_fields: dict[str, Any] = {"tracked": tracked, "user_id": 1 if tracked else 0, "joints": []}
        if tracked:
            skeleton_fields["joints"] = [
                SkeletonJoint(name=n, position_m=(float(est[i][0]), float(est[i][1]), float(est[i][2])),
                              confidence=float(conf[i]))
                for i, n in enumerate(SKELETON_JOINTS)
            ]
        truth = KinectTruth(
            t_s=float(t_s),
            joints_m=joints,
            right_hand_m=joints["right_hand"].copy(),
            robot_tool_m=tool,
            object_position_m=obj.copy(),
            object_size_m=self.scenario.object_size_m,
            body=self.body.size,
        )
        return KinectFrame(skeleton_fields, self.camera_fields, readings, truth)

    def _joints_at(self, hand_m: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """The body's joints for the right hand at `hand_m` (m, `base`; a new dict of
        read-only arrays) and their rows in `SKELETON_JOINTS` order, solved again only when
        the hand moved (the same result bit for bit: `ReceiverBody.joints` is a function of
        the hand alone)."""
        key = hand_m.tobytes()
        if self._joints_for is None or self._joints_for[0] != key:
            joints = {name: np.array(v, float) for name, v in self.body.joints(hand_m).items()}
            for v in joints.values():
                v.flags.writeable = False
            rows = np.stack([joints[n] for n in SKELETON_JOINTS])
            rows.flags.writeable = False
            self._joints_for = (key, joints, rows)
        return dict(self._joints_for[1]), self._joints_for[2]

    def _tool_at(self, q_rad: np.ndarray) -> np.ndarray:
        """The tool position (m, `base`, read-only) for the arm's joints `q_rad` (rad),
        computed again only when a joint moved."""
        key = q_rad.tobytes()
        if self._tool_for is None or self._tool_for[0] != key:
            tool = np.array(self.arm.tool_position(q_rad), float)
            tool.flags.writeable = False
            self._tool_for = (key, tool)
        return self._tool_for[1]

    def noise_rng(self, index: int) -> np.random.Generator:
        """The depth noise generator of frame `index` (0 for the first `step`): seeded by the
        simulator's seed and the index alone."""
        return np.random.default_rng((self.seed, DEPTH_NOISE_STREAM, index))

    def _render(self, shapes: tuple[list[Capsule], list[Box]]) -> tuple[np.ndarray, bool]:
        """The ideal depth of the scene with `shapes` moved (m, +inf = no hit) and whether it
        differs from the previous render's (`SceneDepthRenderer`)."""
        depth_m = self.depth.render(*shapes)
        return depth_m, self.depth.changed
