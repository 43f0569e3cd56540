"""The DJT optimum for the TRUE receiver: the reference a run's transfer point is scored against.

The planner in the stack plans for the receiver the tracker estimates from the simulated
Kinect (height, arm span, posture, shoulder height, all with the sensor's errors). Here the
same planner code (`services.planner.core.plan_for_receiver`, the episode profile's planner
configuration) plans for the body the simulator really drew: its height, arm span, weight,
posture, seat (the simulated body sits with its thighs level at knee height) and shoulder
height, standing where the scene puts it. The distance between this optimum and the point
the arm went to is the transfer-point error (m, `base` frame): perception and re-planning
errors, not the DJT model's own.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from handover_model import scene
from handover_model.robots import RobotDescription
from robot_sim.kinect.receiver import KNEE_HEIGHT_RATIO, BodySize
from services.planner.anthropometrics import BodyDimensions
from services.planner.config import load_config
from services.planner.core import ReceiverInput, plan_for_receiver
from services.planner.errors import PlannerError
from services.studies.evaluation.population import EpisodeDraw


def true_receiver(draw: EpisodeDraw, use_measured_shoulder_height: bool = True) -> ReceiverInput:
    """The simulated receiver of `draw` as the planner's input (its true body and place)."""
    size = BodySize(draw.height_m, draw.posture)  # type: ignore[arg-type]
    body = BodyDimensions(height_m=draw.height_m, arm_span_m=size.arm_span_m, weight_kg=draw.weight_kg,
                          posture=draw.posture, seat_height_m=KNEE_HEIGHT_RATIO * draw.height_m)  # type: ignore[arg-type]
    shoulder_x_task_m = scene.RECEIVER_SHOULDER_X_BASE_M - scene.TASK_ORIGIN_X_M
    shoulder = size.shoulder_height_above_floor_m if use_measured_shoulder_height else None
    return ReceiverInput(body=body, shoulder_x_task_m=shoulder_x_task_m, shoulder_height_m=shoulder)


def djt_optimum_base_m(draw: EpisodeDraw, planner_config: dict[str, Any],
                       robot: RobotDescription | None = None) -> np.ndarray | None:
    """The DJT transfer point (`base`, m) for the true receiver and object of `draw`, with the
    planner configuration `planner_config` (the profile's ``[services.planner.config]``); None
    when no point is reachable by both the robot and that receiver (a receiver drawn too far or
    too small for the scene: the episode has no reference, its transfer-point error is n/a).
    `robot`: the episode's arm, whose giver stand-in and reach start the planner uses (as the
    planner service does with `handover_model.robots.active()`); None: the default arm's
    (`handover_model.robots.DEFAULT_ROBOT`)."""
    cfg = load_config(planner_config, robot)
    receiver = true_receiver(draw, cfg.model.use_measured_shoulder_height)
    try:
        plan = plan_for_receiver(cfg, receiver, draw.object_mass_kg)
    except PlannerError:
        return None
    return np.asarray(plan.position_base_m, dtype=float)
