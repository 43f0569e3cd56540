"""The receiver's body: a 15-joint OpenNI-style skeleton and the capsules around it.

Body proportions are fractions of the standing height H from the stack's one anthropometric
table (`handover_model.body`: Drillis & Contini (1966), the upper limb scaled so that the arm
span, fingertip to fingertip, equals H as it does on average in adults). The tracker's
body-dimension estimator and the planner read the same table.

Frames: `base` (x forward from the robot, y left, z up), metres. The receiver stands (or sits)
across the table facing the robot (−x); facing −x, its right hand side is +y. Its right
(receiving) shoulder lies in the task plane (`handover_model.scene`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from bus_schema.messages import SKELETON_JOINTS
from handover_model import body, scene
from handover_model.shapes import Capsule

Posture = Literal["standing", "sitting"]

# The receiver's proportions, fractions of H, from the stack's one anthropometric table
# (`handover_model.body`) with the average adult's arm span (L = H).
#: Heights above the floor of the standing skeleton's joints.
FOOT_HEIGHT_RATIO = body.ANKLE_HEIGHT_FRACTION
KNEE_HEIGHT_RATIO = body.KNEE_HEIGHT_FRACTION
HIP_HEIGHT_RATIO = body.HIP_HEIGHT_FRACTION
TORSO_HEIGHT_RATIO = body.TORSO_JOINT_HEIGHT_FRACTION
SHOULDER_HEIGHT_RATIO = body.SHOULDER_HEIGHT_FRACTION
HEAD_CENTRE_HEIGHT_RATIO = body.HEAD_JOINT_HEIGHT_FRACTION
#: Half distances between left and right joints.
SHOULDER_HALF_WIDTH_RATIO = body.AVERAGE_UPPER_LIMB.shoulder_half_width_m
HIP_HALF_WIDTH_RATIO = body.HIP_JOINT_HALF_WIDTH_FRACTION
#: Segment lengths.
UPPER_ARM_RATIO = body.AVERAGE_UPPER_LIMB.upper_arm_m  # shoulder joint -> elbow joint
FOREARM_RATIO = body.AVERAGE_UPPER_LIMB.elbow_to_palm_centre_m  # elbow joint -> hand joint (palm centre)
HAND_TIP_RATIO = body.AVERAGE_UPPER_LIMB.palm_centre_to_fingertip_m  # hand joint -> fingertip
#: Largest forward lean of the upper body when the hand's target is beyond the straight arm:
#: the shoulders move this fraction of H toward the target (trunk flexion about the hips).
MAX_LEAN_RATIO = body.MAX_LEAN_FRACTION
THIGH_RATIO = HIP_HEIGHT_RATIO - KNEE_HEIGHT_RATIO
SHANK_RATIO = KNEE_HEIGHT_RATIO - FOOT_HEIGHT_RATIO


def arm_span_ratio() -> float:
    """Arm span / height implied by the table (fingertip to fingertip, arms out)."""
    return 2.0 * (SHOULDER_HALF_WIDTH_RATIO + UPPER_ARM_RATIO + FOREARM_RATIO + HAND_TIP_RATIO)


@dataclass(frozen=True)
class BodySize:
    """Receiver's body (metres).

    Attributes:
        height_m: standing height H.
        posture: standing or sitting.
    """

    height_m: float = 1.75
    posture: Posture = "standing"

    @property
    def arm_span_m(self) -> float:
        return arm_span_ratio() * self.height_m

    @property
    def upper_arm_m(self) -> float:
        return UPPER_ARM_RATIO * self.height_m

    @property
    def forearm_m(self) -> float:
        return FOREARM_RATIO * self.height_m

    @property
    def hip_height_above_floor_m(self) -> float:
        if self.posture == "standing":
            return HIP_HEIGHT_RATIO * self.height_m
        return KNEE_HEIGHT_RATIO * self.height_m  # thighs level on a seat at knee height

    @property
    def shoulder_height_above_floor_m(self) -> float:
        return self.hip_height_above_floor_m + (SHOULDER_HEIGHT_RATIO - HIP_HEIGHT_RATIO) * self.height_m


def _two_link_elbow(shoulder: np.ndarray, hand: np.ndarray, l1: float, l2: float,
                    pole: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elbow position of a two-link arm reaching `hand` from `shoulder`, bent toward `pole`.

    A target out of reach is pulled back along the shoulder→hand line to 99.5 % of the reach.

    Returns:
        (elbow (3,), hand actually reached (3,)).
    """
    v = hand - shoulder
    dist = float(np.linalg.norm(v))
    reach = 0.995 * (l1 + l2)
    lo = abs(l1 - l2) + 1e-3
    if dist > reach:
        hand = shoulder + v * (reach / dist)
        dist = reach
    elif dist < lo:
        hand = shoulder + v * (lo / max(dist, 1e-9))
        dist = lo
    axis = (hand - shoulder) / dist
    cos_a = (l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist)
    along = l1 * cos_a
    perp_len = l1 * np.sqrt(max(0.0, 1.0 - cos_a * cos_a))
    perp = pole - (pole @ axis) * axis
    n = np.linalg.norm(perp)
    perp = perp / n if n > 1e-9 else np.array([0.0, 0.0, -1.0])
    return shoulder + axis * along + perp * perp_len, hand


class ReceiverBody:
    """Skeleton and capsules of the receiver for a given right-hand position.

    Args:
        size: body size and posture.
        torso_xy_base_m: (x, y) of the torso centre in `base`; by default the scene's
            receiver placement, shifted so the right shoulder lies in the task plane.
    """

    def __init__(self, size: BodySize, torso_xy_base_m: np.ndarray | None = None) -> None:
        self.size = size
        h = size.height_m
        floor_z = -scene.BASE_HEIGHT_ABOVE_FLOOR_M
        if torso_xy_base_m is None:
            torso_xy_base_m = np.array(
                [scene.RECEIVER_SHOULDER_X_BASE_M, scene.TASK_PLANE_Y_M - SHOULDER_HALF_WIDTH_RATIO * h]
            )
        x0, y0 = (float(c) for c in torso_xy_base_m)
        self.floor_z_m = floor_z
        hip_z = floor_z + size.hip_height_above_floor_m
        sh_z = floor_z + size.shoulder_height_above_floor_m
        sw = SHOULDER_HALF_WIDTH_RATIO * h
        hw = HIP_HALF_WIDTH_RATIO * h
        j: dict[str, np.ndarray] = {}
        # Facing −x: the right side is +y.
        j["neck"] = np.array([x0, y0, sh_z])
        j["head"] = np.array([x0, y0, sh_z + (HEAD_CENTRE_HEIGHT_RATIO - SHOULDER_HEIGHT_RATIO) * h])
        j["torso"] = np.array([x0, y0, hip_z + (TORSO_HEIGHT_RATIO - HIP_HEIGHT_RATIO) * h])
        j["right_shoulder"] = np.array([x0, y0 + sw, sh_z])
        j["left_shoulder"] = np.array([x0, y0 - sw, sh_z])
        j["right_hip"] = np.array([x0, y0 + hw, hip_z])
        j["left_hip"] = np.array([x0, y0 - hw, hip_z])
        for side, sy in (("right", +1.0), ("left", -1.0)):
            hip = j[f"{side}_hip"]
            if size.posture == "standing":
                j[f"{side}_knee"] = hip - np.array([0.0, 0.0, THIGH_RATIO * h])
                j[f"{side}_foot"] = j[f"{side}_knee"] - np.array([0.0, 0.0, SHANK_RATIO * h])
            else:
                j[f"{side}_knee"] = hip + np.array([-THIGH_RATIO * h, 0.0, 0.0])
                j[f"{side}_foot"] = np.array(
                    [j[f"{side}_knee"][0], hip[1], floor_z + FOOT_HEIGHT_RATIO * h]
                )
        # Left arm hangs at rest.
        ls = j["left_shoulder"]
        j["left_elbow"] = ls + np.array([0.0, -0.02, -size.upper_arm_m])
        j["left_hand"] = j["left_elbow"] + np.array([-0.05, 0.0, -np.sqrt(size.forearm_m**2 - 0.05**2)])
        self._static = j

    @property
    def rest_hand_m(self) -> np.ndarray:
        """The right hand at rest (m, `base`): hanging when standing, on the thigh when sitting."""
        s = self._static["right_shoulder"]
        if self.size.posture == "standing":
            return s + np.array([-0.08, 0.03, -(self.size.upper_arm_m + self.size.forearm_m) * 0.97])
        hip = self._static["right_hip"]
        return hip + np.array([-0.6 * THIGH_RATIO * self.size.height_m, 0.0, 0.10])

    @property
    def reach_m(self) -> float:
        """Right shoulder to hand joint, arm straight (m)."""
        return self.size.upper_arm_m + self.size.forearm_m

    def joints(self, right_hand_m: np.ndarray) -> dict[str, np.ndarray]:
        """All 15 joints (m, `base`) with the right hand placed at `right_hand_m` (or as close
        as the arm reaches); the elbow bends down and outward. A target beyond the straight
        arm makes the upper body lean toward it (horizontally, at most `MAX_LEAN_RATIO`·H at
        the shoulders, half of that at the torso joint; hips and legs stay)."""
        j = dict(self._static)
        target = np.asarray(right_hand_m, float)
        shoulder = j["right_shoulder"]
        excess = float(np.linalg.norm(target - shoulder)) - 0.995 * self.reach_m
        toward = (target - shoulder) * np.array([1.0, 1.0, 0.0])
        norm = float(np.linalg.norm(toward))
        if excess > 0.0 and norm > 1e-9:
            # The horizontal shift L of the shoulder along u that brings the target back to the
            # straight arm R: |d − u L| = R, smaller root; capped at MAX_LEAN_RATIO·H.
            d = target - shoulder
            reach = 0.995 * self.reach_m
            disc = norm * norm - float(d @ d) + reach * reach
            cap = MAX_LEAN_RATIO * self.size.height_m
            # disc < 0: no horizontal lean brings it back (e.g. a target below the hanging
            # hand): the trunk stays and the hand goes as far as the arm reaches.
            lean = min(norm - float(np.sqrt(disc)), cap) if disc >= 0.0 else 0.0
            shift = toward / norm * max(lean, 0.0)
            for name in ("neck", "head", "right_shoulder", "left_shoulder", "left_elbow", "left_hand"):
                j[name] = j[name] + shift
            j["torso"] = j["torso"] + 0.5 * shift
        shoulder = j["right_shoulder"]
        pole = np.array([0.3, 1.0, -1.0])
        elbow, hand = _two_link_elbow(
            shoulder, np.asarray(right_hand_m, float), self.size.upper_arm_m, self.size.forearm_m, pole
        )
        j["right_elbow"] = elbow
        j["right_hand"] = hand
        return {name: j[name] for name in SKELETON_JOINTS}

    def capsules(self, joints: dict[str, np.ndarray]) -> list[Capsule]:
        """Capsules (metres) that make up the body's surface for the given joints."""
        return self.moving_capsules(joints) + self._leg_capsules(joints)

    def static_capsules(self) -> list[Capsule]:
        """The capsules that never move: the legs (`joints` never moves hips, knees, feet),
        equal to the leg capsules of `capsules(joints(hand))` for any hand."""
        return self._leg_capsules(self._static)

    def moving_capsules(self, joints: dict[str, np.ndarray]) -> list[Capsule]:
        """The capsules of the head, neck, trunk and arms (m) for the given joints: those that
        follow the right hand (the arm itself, and the upper body when it leans)."""
        h = self.size.height_m
        c = []
        up = np.array([0.0, 0.0, 1.0])
        c.append(Capsule(joints["head"], joints["head"], 0.058 * h))
        c.append(Capsule(joints["neck"] - 0.02 * up, joints["head"] - 0.05 * h * up, 0.030 * h))
        # Trunk: two capsules side by side give a flattish chest.
        for side in ("left", "right"):
            sh = joints[f"{side}_shoulder"]
            hip = joints[f"{side}_hip"]
            top = 0.55 * sh + 0.45 * joints["neck"] - 0.04 * h * up
            c.append(Capsule(top, hip + 0.02 * h * up, 0.058 * h))
        for side in ("left", "right"):
            sh, el, hd = (joints[f"{side}_{n}"] for n in ("shoulder", "elbow", "hand"))
            c.append(Capsule(sh, el, 0.026 * h))
            c.append(Capsule(el, hd, 0.021 * h))
            fore = hd - el
            fore /= max(np.linalg.norm(fore), 1e-9)
            c.append(Capsule(hd - 0.02 * h * fore, hd + 0.025 * h * fore, 0.025 * h))
        return c

    def _leg_capsules(self, joints: dict[str, np.ndarray]) -> list[Capsule]:
        h = self.size.height_m
        up = np.array([0.0, 0.0, 1.0])
        c = []
        for side in ("left", "right"):
            hip, kn, ft = (joints[f"{side}_{n}"] for n in ("hip", "knee", "foot"))
            c.append(Capsule(hip, kn, 0.040 * h))
            c.append(Capsule(kn, ft, 0.030 * h))
            c.append(Capsule(ft, ft + np.array([-0.08 * h, 0.0, 0.0]) - 0.015 * h * up, 0.022 * h))
        return c


def min_jerk(s: np.ndarray | float) -> np.ndarray | float:
    """Minimum-jerk profile 10 s³ − 15 s⁴ + 6 s⁵ of the normalised time s (clipped to 0..1)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)
