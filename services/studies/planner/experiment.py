"""Candidate transfer positions of the thesis's human–robot experiment (§2.5.1).

Tasks 1 and 2 (empty cup, 65 g): P1 is the DJT point; P2 and P3 are at the same height,
15 cm farther from the receiver (toward the robot, −x) and 15 cm closer to it (+x); P4 is at
the same distance from the receiver, 15 cm lower when the receiver stands (task 1) and 15 cm
higher when the receiver sits (task 2).

Tasks 3 and 4 (sitting receiver): P1 is the DJT point for the object actually handed over (a
full cup, 335 g, in task 3), P2 the DJT point computed for a hypothetical light object (the
empty cup, 65 g).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from services.planner.djt.arms import Dyad
from services.planner.djt.cost import djt_cost
from services.planner.djt.settings import DJTSettings
from services.planner.frames import TaskPlaneFrame
from services.planner.transfer_plan import TransferPlan

OFFSET_M = 0.15


@dataclass(frozen=True)
class Candidate:
    """One candidate transfer position.

    Attributes:
        name: ``P1`` … ``P4``.
        description: how it was chosen.
        position_task_m: (x, z) in the task plane, m.
        position_base_m: the same point in `base`, m.
        cost: E_DJT there (inf when one of the actors cannot reach it), N² m².
        feasible: both actors can reach it above the table.
    """

    name: str
    description: str
    position_task_m: tuple[float, float]
    position_base_m: tuple[float, float, float]
    cost: float
    feasible: bool


def _candidate(
    name: str,
    description: str,
    p: np.ndarray,
    dyad: Dyad,
    mass_kg: float,
    settings: DJTSettings,
    frame: TaskPlaneFrame,
) -> Candidate:
    cost, feasible = djt_cost(dyad, np.array(p[0]), np.array(p[1]), mass_kg, settings)
    b = frame.task_to_base(p)
    return Candidate(
        name=name,
        description=description,
        position_task_m=(float(p[0]), float(p[1])),
        position_base_m=(float(b[0]), float(b[1]), float(b[2])),
        cost=float(cost),
        feasible=bool(feasible),
    )


def four_positions(
    plan: TransferPlan,
    settings: DJTSettings = DJTSettings(),
    frame: TaskPlaneFrame = TaskPlaneFrame(),
    offset_m: float = OFFSET_M,
) -> list[Candidate]:
    """P1–P4 of tasks 1 (receiver standing: P4 lower) and 2 (sitting: P4 higher)."""
    p1 = np.array(plan.position_task_m)
    sitting = plan.receiver_posture == "sitting"
    dz = offset_m if sitting else -offset_m
    rows = [
        ("P1", "DJT optimum", p1),
        ("P2", f"{offset_m * 100:.0f} cm farther from the receiver", p1 + [-offset_m, 0.0]),
        ("P3", f"{offset_m * 100:.0f} cm closer to the receiver", p1 + [offset_m, 0.0]),
        (
            "P4",
            f"{offset_m * 100:.0f} cm {'higher' if sitting else 'lower'}, same distance",
            p1 + [0.0, dz],
        ),
    ]
    return [
        _candidate(n, d, p, plan.dyad, plan.object_mass_kg, settings, frame) for n, d, p in rows
    ]


def heavy_light_positions(
    heavy_plan: TransferPlan,
    light_plan: TransferPlan,
    settings: DJTSettings = DJTSettings(),
    frame: TaskPlaneFrame = TaskPlaneFrame(),
) -> list[Candidate]:
    """Tasks 3/4: P1 = DJT point for the heavy object, P2 = DJT point for a light one.

    Costs are evaluated with the heavy object's mass (the object actually handed over).
    """
    mass = heavy_plan.object_mass_kg
    return [
        _candidate(
            "P1",
            f"DJT optimum for {heavy_plan.object_mass_kg * 1000:.0f} g",
            np.array(heavy_plan.position_task_m),
            heavy_plan.dyad,
            mass,
            settings,
            frame,
        ),
        _candidate(
            "P2",
            f"DJT optimum for a light {light_plan.object_mass_kg * 1000:.0f} g object",
            np.array(light_plan.position_task_m),
            heavy_plan.dyad,
            mass,
            settings,
            frame,
        ),
    ]
