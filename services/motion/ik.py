"""Inverse kinematics of the profile's arm (`handover_model.robots`) with PlaCo.

Frames: every pose is the arm's tool frame (`RobotDescription.tool_frame`) in the scene's
`base` frame (x forward, y left, z up), metres; rotations are 3×3 matrices whose columns are
the tool axes in `base`.

Every arm's tool frame follows one convention (docs/robots.md): it sits between the
fingertips, its z axis is the approach axis (wrist → fingertips), its y axis is the axis the
jaws close along, so the pads' faces are normal to y; x = y × z. The default arm's
`right_gripper` is such a frame (0.1327 m beyond `right_gripper_base`, the fingers sliding along
`r_gripper_l_finger_joint`'s axis 0 1 0); other arms get one added where their URDF has none.

"Object upright, fingers' faces vertical" (thesis Fig. 15: the grip force is normal to the
vertical plane that holds the pull and the weight) is `UPRIGHT_ROTATION`:
    z_tool = −z_base (fingers point straight down, the object hangs upright between them),
    y_tool = +y_base (horizontal: the pads' faces are vertical planes parallel to the task
                      plane, and the grip force is normal to the task plane),
    x_tool = −x_base.
The other yaw (y_tool = −y_base) is the same grasp but puts the default arm's wrist roll `right_w2`
at its ±3.06 rad limit for typical transfer points, so it is not used.

The IK is a PlaCo `KinematicsSolver` on the arm's full model with the floating base and
every joint but the arm's chain masked (locked at zero): position task and orientation task on
the tool frame (weight 1 each), a joints (posture) task toward a comfortable
posture with a small weight, joint position limits and joint velocity limits.

The model is loaded from the URDF text without its `<visual>` and `<collision>` elements
(`kinematic_urdf_text`): the IK uses only joints, frames, limits and inertias, and the meshes
PlaCo would otherwise load for the visual model cost ≈ 245 MB of memory and ≈ 2 s of start-up.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from handover_model import robots
from handover_model.robots import RobotDescription
from services.motion.config import MotionConfig
from services.motion.errors import IkError, IkInfeasibleError, IkNoProgressError, MotionError

log = logging.getLogger(__name__)

#: Tool orientation that keeps a held object upright with the fingers' faces vertical.
UPRIGHT_ROTATION = np.array(
    [
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
    ]
)


def kinematic_urdf_text(robot: RobotDescription | None = None) -> str:
    """The arm's URDF as text with every link's `<visual>` and `<collision>` removed, placed in
    `base` with its tool frame (`handover_model.robots.model_urdf_text`).

    Joints, links, frames, limits and inertias are unchanged, so the kinematics are those of
    the full model; no mesh file is referenced, so nothing is read from disk but the URDF.

    Raises:
        MotionError: the URDF is missing or not valid XML.
    """
    robot = robot or robots.active()
    try:
        return robots.model_urdf_text(robot)
    except robots.RobotDescriptionError as exc:
        raise MotionError(f"could not read {robot.name}'s URDF: {exc}") from exc


def rotation_error_rad(rotation_a: np.ndarray, rotation_b: np.ndarray) -> float:
    """Angle (rad) of the rotation that takes `rotation_a` to `rotation_b`."""
    cos_angle = (np.trace(rotation_a.T @ rotation_b) - 1.0) / 2.0
    return float(math.acos(min(1.0, max(-1.0, cos_angle))))


@dataclass(frozen=True)
class IkResult:
    """Outcome of an IK solve or step.

    Attributes:
        q_rad: the arm's joint positions (n,), rad, in its description's order.
        position_error_m: distance between the tool and the target, m.
        orientation_error_rad: angle between the tool and target orientations, rad.
        iterations: QP iterations used.
    """

    q_rad: np.ndarray
    position_error_m: float
    orientation_error_rad: float
    iterations: int


class ArmIk:
    """PlaCo IK for the arm: offline solves for goal poses and one step per tick.

    Not thread-safe: one instance per control loop.
    """

    def __init__(self, config: MotionConfig | None = None, description: RobotDescription | None = None) -> None:
        import placo  # heavy import, only where IK is needed

        self.config = config or MotionConfig()
        self.description = description or robots.active()
        desc = self.description
        if len(self.config.posture_rad) != desc.dof:
            raise MotionError(f"motion config posture_rad has {len(self.config.posture_rad)} values; "
                              f"{desc.name} has {desc.dof} joints ({', '.join(desc.joints)})")
        try:
            self.robot = placo.RobotWrapper(str(robots.urdf_path(desc)), placo.Flags.ignore_collisions,
                                            kinematic_urdf_text(desc))
        except (RuntimeError, robots.RobotDescriptionError) as exc:
            raise MotionError(f"PlaCo could not load {desc.name}'s URDF: {exc}") from exc
        self.joint_names = desc.joints
        self.tool_frame = desc.tool_frame
        self._q_index = np.array([self.robot.get_joint_offset(n) for n in self.joint_names])
        self._v_index = np.array([self.robot.get_joint_v_offset(n) for n in self.joint_names])
        limits = np.array([self.robot.get_joint_limits(n) for n in self.joint_names])
        self.lower_rad = limits[:, 0].copy()
        self.upper_rad = limits[:, 1].copy()
        urdf_velocity = np.array(desc.velocity_rad_s) if desc.velocity_rad_s else \
            np.array(self.robot.model.velocityLimit)[self._v_index]
        self.velocity_limit_rad_s = urdf_velocity * self.config.velocity_scale
        for name, v in zip(self.joint_names, self.velocity_limit_rad_s):
            self.robot.set_velocity_limit(name, float(v))

        solver = placo.KinematicsSolver(self.robot)
        solver.mask_fbase(True)
        for name in self.robot.joint_names():
            if name not in self.joint_names:
                solver.mask_dof(name)
        solver.enable_joint_limits(True)
        solver.enable_velocity_limits(True)
        self.solver = solver
        self._position_task = solver.add_position_task(self.tool_frame, np.zeros(3))
        self._position_task.configure("tool_position", "soft", 1.0)
        self._orientation_task = solver.add_orientation_task(self.tool_frame, np.eye(3))
        self._orientation_task.configure("tool_orientation", "soft", 1.0)
        self._posture_task = solver.add_joints_task()
        self._posture_task.set_joints(
            {n: float(q) for n, q in zip(self.joint_names, self.config.posture_rad)}
        )
        self._posture_task.configure("posture", "soft", self.config.posture_weight)
        self._margin_rad = 1e-6

    # ------------------------------------------------------------------ kinematics

    def clip_to_limits(self, q_rad: np.ndarray) -> np.ndarray:
        """`q_rad` clipped into the joint position limits (rad)."""
        return np.clip(q_rad, self.lower_rad + self._margin_rad, self.upper_rad - self._margin_rad)

    def _set_q(self, q_rad: np.ndarray) -> None:
        q = self.robot.state.q
        q[self._q_index] = q_rad
        self.robot.state.q = q
        self.robot.update_kinematics()

    def _get_q(self) -> np.ndarray:
        return np.array(self.robot.state.q[self._q_index])

    def tool_pose(self, q_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forward kinematics: (position_m (3,), rotation (3, 3)) of the tool in `base`."""
        self._set_q(np.asarray(q_rad, dtype=float))
        return self._current_tool_pose()

    def _current_tool_pose(self) -> tuple[np.ndarray, np.ndarray]:
        transform = self.robot.get_T_world_frame(self.tool_frame)
        return transform[:3, 3].copy(), transform[:3, :3].copy()

    def _errors(self, position_m: np.ndarray, rotation: np.ndarray) -> tuple[float, float]:
        p, r = self._current_tool_pose()
        return float(np.linalg.norm(p - position_m)), rotation_error_rad(r, rotation)

    def _qp_step(self) -> None:
        try:
            self.solver.solve(True)
        except RuntimeError as exc:
            if "QPError" in str(exc):
                raise IkInfeasibleError(
                    f"PlaCo QP has no solution ({exc}); the start configuration may violate "
                    "the joint limits or the tasks conflict with them"
                ) from exc
            raise IkError(f"PlaCo IK step failed: {exc}") from exc
        self.robot.update_kinematics()

    def _set_targets(self, position_m: np.ndarray, rotation: np.ndarray) -> None:
        self._position_task.target_world = np.asarray(position_m, dtype=float)
        self._orientation_task.R_world_frame = np.asarray(rotation, dtype=float)

    # ------------------------------------------------------------------ solves

    def solve(
        self, position_m: np.ndarray, rotation: np.ndarray, q_seed_rad: np.ndarray
    ) -> IkResult:
        """Solve IK for a goal pose from `q_seed_rad`, then from other seeds if that fails.

        Local IK gets stuck at joint limits for some targets (about 15 % of uniformly random
        reachable poses from the home posture). The solve is retried from the configured
        posture and then from `config.ik_restarts` random configurations drawn with a fixed
        seed (so a given goal always gives the same answer); the first solution wins.

        Raises:
            IkInfeasibleError: the QP has no solution from any seed.
            IkNoProgressError: no seed reaches the tolerance; the message is the best attempt's.
        """
        seeds = [np.asarray(q_seed_rad, dtype=float), np.asarray(self.config.posture_rad, dtype=float)]
        rng = np.random.default_rng(self.config.ik_restart_seed)
        n_joints = len(self.joint_names)
        seeds += list(rng.uniform(self.lower_rad, self.upper_rad, size=(self.config.ik_restarts, n_joints)))
        first_error: IkError | None = None
        iterations = 0
        for seed in seeds:
            try:
                result = self.solve_local(position_m, rotation, seed)
            except IkError as exc:
                first_error = first_error or exc
                iterations += getattr(exc, "iterations", 0)
                continue
            return IkResult(result.q_rad, result.position_error_m, result.orientation_error_rad,
                            iterations + result.iterations)
        assert first_error is not None
        raise type(first_error)(f"{first_error} (also tried {len(seeds) - 1} other start postures)")

    def solve_local(
        self, position_m: np.ndarray, rotation: np.ndarray, q_seed_rad: np.ndarray
    ) -> IkResult:
        """Solve IK for a goal pose, starting from `q_seed_rad` only (many iterations).

        Each iteration is one QP step whose joint motion is bounded by the velocity limits
        times `config.ik_step_s` (a damped, limit-respecting Newton step).

        Raises:
            IkInfeasibleError: the QP has no solution.
            IkNoProgressError: the error stopped decreasing above the tolerance (out of reach,
                or stuck at a joint limit); the message gives the remaining error.
        """
        cfg = self.config
        position_m = np.asarray(position_m, dtype=float)
        rotation = np.asarray(rotation, dtype=float)
        self._set_q(self.clip_to_limits(np.asarray(q_seed_rad, dtype=float)))
        self._set_targets(position_m, rotation)
        self.solver.dt = cfg.ik_step_s
        window = cfg.ik_no_progress_iterations
        history: list[float] = []
        pos_err, ori_err = self._errors(position_m, rotation)
        for iteration in range(1, cfg.ik_max_iterations + 1):
            self._qp_step()
            pos_err, ori_err = self._errors(position_m, rotation)
            if pos_err <= cfg.position_tolerance_m and ori_err <= cfg.orientation_tolerance_rad:
                return IkResult(self._get_q(), pos_err, ori_err, iteration)
            # One scalar error: metres plus radians scaled by the ratio of tolerances.
            scale = cfg.position_tolerance_m / cfg.orientation_tolerance_rad
            history.append(pos_err + scale * ori_err)
            if len(history) > window and history[-1] > (1.0 - cfg.ik_no_progress_ratio) * history[-1 - window]:
                error = IkNoProgressError(
                    f"IK made no progress: tool still {pos_err * 1000:.1f} mm and "
                    f"{math.degrees(ori_err):.1f} deg from the target "
                    f"{position_m.round(3).tolist()}; the pose is probably out of reach"
                )
                error.iterations = iteration
                raise error
        error = IkNoProgressError(
            f"IK did not converge in {cfg.ik_max_iterations} iterations: tool still "
            f"{pos_err * 1000:.1f} mm and {math.degrees(ori_err):.1f} deg from the target"
        )
        error.iterations = cfg.ik_max_iterations
        raise error

    def track_step(
        self, position_m: np.ndarray, rotation: np.ndarray, q_current_rad: np.ndarray, dt_s: float
    ) -> IkResult:
        """One IK step toward a moving target for one control tick of `dt_s` seconds.

        The joint motion of the step respects the joint velocity limits over `dt_s` and the
        position limits. Returns the new joint positions and the remaining tool error.

        Raises:
            IkInfeasibleError: the QP has no solution.
        """
        self._set_q(np.asarray(q_current_rad, dtype=float))
        self._set_targets(position_m, rotation)
        self.solver.dt = dt_s
        self._qp_step()
        pos_err, ori_err = self._errors(np.asarray(position_m, dtype=float), np.asarray(rotation))
        return IkResult(self._get_q(), pos_err, ori_err, 1)
