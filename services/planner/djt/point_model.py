"""The DJT cost and constraints at one point in scalar (math-module) form, for the SLSQP
refinement of `services.planner.djt.optimum`."""

from __future__ import annotations

import math

import numpy as np

from services.planner.djt.arms import Dyad, distance_limits_m
from services.planner.djt.settings import DJTSettings, object_loads_kg


class PointModel:
    """Scalar (math-module) cost and constraints at one point, for the SLSQP refinement.

    Same equations as `djt_cost`, without numpy's per-call overhead on scalars.
    """

    def __init__(self, dyad: Dyad, object_mass_kg: float, settings: DJTSettings) -> None:
        giver_load, receiver_load = object_loads_kg(object_mass_kg, settings)
        self.table_z = settings.min_height_above_table_m
        self.g = settings.gravity_m_s2
        self.q1_lo, self.q1_hi = settings.shoulder_angle_range_rad
        #: Indices (giver low, giver high, receiver low, receiver high) of the shoulder
        #: limits handed to SLSQP (see `watch_shoulder_limits_near`).
        self.watched: list[int] = [0, 1, 2, 3]
        self.arms = []
        for actor, load in ((dyad.giver, giver_load), (dyad.receiver, receiver_load)):
            a = actor.arm
            d_min, d_max = distance_limits_m(a, settings)
            distal = a.forearm_hand_mass_kg * a.forearm_hand_com_m + load * a.forearm_to_grasp_m
            proximal = a.upper_arm_mass_kg * a.upper_arm_com_m + (
                a.forearm_hand_mass_kg + load
            ) * a.upper_arm_m
            self.arms.append(
                (actor.shoulder_x_m, actor.shoulder_z_m, actor.facing, a.upper_arm_m,
                 a.forearm_to_grasp_m, proximal, distal, d_min, d_max)
            )

    def cost(self, p: np.ndarray | tuple[float, float]) -> float:
        """E_DJT at p (+inf outside either annulus)."""
        x, z = float(p[0]), float(p[1])
        total = 0.0
        for sx, sz, facing, l1, l2, proximal, distal, _, _ in self.arms:
            u, w = facing * (x - sx), z - sz
            c2 = (u * u + w * w - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
            if c2 > 1.0 or c2 < -1.0:
                return math.inf
            q2 = math.acos(c2)
            q1 = math.atan2(w, u) - math.atan2(l2 * math.sin(q2), l1 + l2 * c2)
            t_e = self.g * distal * math.cos(q1 + q2)
            t_s = self.g * proximal * math.cos(q1) + t_e
            total += t_s * t_s + t_e * t_e
        return total

    def _upper_arm_angles(self, x: float, z: float) -> list[float]:
        """q1 (rad) of each arm at (x, z) on the natural branch (c2 clipped outside the annulus)."""
        out = []
        for sx, sz, facing, l1, l2, *_rest in self.arms:
            u, w = facing * (x - sx), z - sz
            c2 = min(1.0, max(-1.0, (u * u + w * w - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)))
            s2 = math.sqrt(1.0 - c2 * c2)
            q1 = math.atan2(w, u) - math.atan2(l2 * s2, l1 + l2 * c2)
            out.append((q1 + math.pi) % (2.0 * math.pi) - math.pi)
        return out

    def watch_shoulder_limits_near(self, p: np.ndarray, margin_rad: float) -> None:
        """Give SLSQP only the shoulder limits within `margin_rad` of binding at `p`.

        q1's gradient grows without bound as an arm straightens (at the reach limit), so a
        far-off shoulder limit would only disturb the line search there.
        """
        self.watched = [
            k for k, slack in enumerate(self._all_shoulder_slacks(float(p[0]), float(p[1])))
            if slack < margin_rad
        ]

    def _all_shoulder_slacks(self, x: float, z: float) -> list[float]:
        return [s for q1 in self._upper_arm_angles(x, z) for s in (q1 - self.q1_lo, self.q1_hi - q1)]

    def _shoulder_range_slacks(self, x: float, z: float) -> list[float]:
        slacks = self._all_shoulder_slacks(x, z)
        return [slacks[k] for k in self.watched]

    def constraints(self, p: np.ndarray) -> np.ndarray:
        """Slacks (≥ 0 ok): [table, giver reach, giver fold, receiver reach, receiver fold,
        then the watched shoulder limits]."""
        x, z = float(p[0]), float(p[1])
        out = [z - self.table_z]
        for sx, sz, *_rest, d_min, d_max in self.arms:
            d = math.hypot(x - sx, z - sz)
            out += [d_max - d, d - d_min]
        return np.array(out + self._shoulder_range_slacks(x, z))

    def constraints_jacobian(self, p: np.ndarray, h: float = 1e-7) -> np.ndarray:
        x, z = float(p[0]), float(p[1])
        rows = [[0.0, 1.0]]
        for sx, sz, *_rest in self.arms:
            d = max(math.hypot(x - sx, z - sz), 1e-12)
            gx, gz = (x - sx) / d, (z - sz) / d
            rows += [[-gx, -gz], [gx, gz]]
        # Shoulder-range rows by central differences (q1 is smooth inside the annulus).
        dx = np.subtract(self._shoulder_range_slacks(x + h, z), self._shoulder_range_slacks(x - h, z))
        dz = np.subtract(self._shoulder_range_slacks(x, z + h), self._shoulder_range_slacks(x, z - h))
        return np.vstack([np.array(rows), np.stack([dx, dz], axis=1).reshape(-1, 2) / (2.0 * h)])
