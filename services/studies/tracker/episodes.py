"""Seeded handover episodes from the simulated Kinect, as bus messages.

An episode: the robot's arm moves (minimum-jerk in joint space) from its home posture to
a transfer point above the table, holding the object between its fingers; the receiver
(random height and posture) reaches for the object with a minimum-jerk hand motion and ends
with its hand on the object, 7 cm from the robot's tool frame. Used by the evaluation and
by `handover-study record`. Frames: the scene's `base` frame, metres, seconds.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from bus_schema.messages import DepthImage, JointState, SimTruth, Skeleton
from handover_model import scene
from handover_model import robots
from robot_sim.kinect import ArmGeometry, KinectScenario, KinectSim
from robot_sim.kinect.receiver import min_jerk
from services.tracker.errors import TrackerError

FRAME_RATE_HZ = 30.0
EPISODE_DURATION_S = 4.0
#: The receiver's hand ends this far from the robot's tool, on the receiver's side (m, +x).
HAND_GRASP_OFFSET_M = np.array([0.07, 0.0, 0.0])


@dataclass(frozen=True)
class EpisodeFrame:
    """One 30 Hz frame of an episode: the messages a bridge would publish, and the truth."""

    t_s: float
    joint_state: JointState
    skeleton: Skeleton
    depth: DepthImage
    truth: SimTruth


def solve_arm_ik(arm: ArmGeometry, target_m: np.ndarray, q0_rad: np.ndarray) -> np.ndarray:
    """Joint positions (7,) that put the tool at `target_m` (position only), within limits.

    Least squares on pinocchio's forward kinematics (scipy), with a small pull toward `q0`.

    Raises:
        TrackerError: when the target is out of reach (residual above 5 mm).
    """
    lim = arm.model.limits
    q0 = np.clip(np.asarray(q0_rad, float), lim.lower_rad + 1e-3, lim.upper_rad - 1e-3)

    def residual(q: np.ndarray) -> np.ndarray:
        return np.concatenate([arm.tool_position(q) - target_m, 0.01 * (q - q0)])

    sol = least_squares(residual, q0, bounds=(lim.lower_rad, lim.upper_rad), xtol=1e-10, ftol=1e-10)
    err = float(np.linalg.norm(arm.tool_position(sol.x) - target_m))
    if err > 0.005:
        raise TrackerError(f"transfer point {np.round(target_m, 3)} out of the arm's reach (miss {err * 1000:.0f} mm)")
    return sol.x


def episode_scenario(seed: int) -> tuple[KinectScenario, np.ndarray, float]:
    """Random but seeded episode set-up.

    Returns:
        (scenario without hand target, transfer point (3,) in `base`, robot reach duration s).
    """
    rng = np.random.default_rng(seed)
    height = float(rng.uniform(1.55, 1.95))
    posture = "standing" if rng.random() < 0.75 else "sitting"
    transfer_task = np.array([rng.uniform(0.10, 0.25), rng.uniform(0.25, 0.40)])
    transfer = scene.task_to_base(transfer_task)
    scenario = KinectScenario(
        height_m=height,
        posture=posture,
        reach_start_s=float(rng.uniform(0.6, 1.2)),
        reach_duration_s=float(rng.uniform(1.0, 1.6)),
    )
    return scenario, transfer, float(rng.uniform(1.5, 2.2))


def run_episode(seed: int, arm: ArmGeometry | None = None) -> Iterator[EpisodeFrame]:
    """Frames of the episode `seed` at 30 Hz for `EPISODE_DURATION_S`."""
    arm = arm or ArmGeometry()
    scenario, transfer, robot_duration = episode_scenario(seed)
    q_home = np.array(robots.active().home_rad)
    q_goal = solve_arm_ik(arm, transfer, q_home)
    hand_target = transfer + HAND_GRASP_OFFSET_M
    scenario = KinectScenario(**{**scenario.__dict__, "hand_target_base_m": tuple(hand_target)})
    sim = KinectSim(seed=seed, scenario=scenario, arm_geometry=arm)
    n = int(round(EPISODE_DURATION_S * FRAME_RATE_HZ))
    prev_tool = None
    for k in range(n):
        t = k / FRAME_RATE_HZ
        q = q_home + min_jerk(t / robot_duration) * (q_goal - q_home)
        tool = arm.tool_position(q)
        frame = sim.step(t, q, object_position_m=tool)
        stamp = int(t * 1e9)
        speed = 0.0 if prev_tool is None else float(np.linalg.norm(tool - prev_tool) * FRAME_RATE_HZ)
        prev_tool = tool
        yield EpisodeFrame(
            t_s=t,
            joint_state=JointState(
                seq=k, stamp_ns=stamp, source="sim", names=list(robots.active().joints),
                position_rad=[float(v) for v in q], velocity_rad_s=[0.0] * len(q), holding=False,
            ),
            skeleton=Skeleton(seq=k, stamp_ns=stamp, source="sim", **frame.skeleton_fields),
            depth=DepthImage(seq=k, stamp_ns=stamp, source="sim", **frame.depth_fields),
            truth=SimTruth(
                seq=k, stamp_ns=stamp, source="sim",
                object_position_m=tuple(float(v) for v in tool),
                receiver_hand_position_m=tuple(float(v) for v in frame.truth.right_hand_m),
                tool_position_m=tuple(float(v) for v in tool),
                tool_speed_m_s=speed,
            ),
        )
