"""Command-line description of a dyad (two bodies, their postures and the scene) for the
planner's bus-free answers: `handover-planner plan` and `handover-study experiment`.

Bodies are ``H,L,W`` (height m, arm span m, weight kg) or a named body; the scene is in the
task plane (x toward the receiver, z above the table top, m).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from handover_model import robots
from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN, BodyDimensions
from services.planner.config import PlannerConfig, load_config
from services.planner.core import timing_for
from services.planner.transfer_plan import DyadGeometry, TransferPlan, plan_transfer
from services.planner.errors import PlannerError
from services.runtime import ProfileError, load_profile

#: The objects of the thesis's human–robot experiment (§2.5.1): the empty and the full cup, kg.
EMPTY_CUP_KG = 0.065
FULL_CUP_KG = 0.335

NAMED_BODIES = {"robot": ROBOT_AS_HUMAN, "figure3": FIGURE3_ACTOR}


def parse_body(text: str, posture: str, seat_height_m: float) -> BodyDimensions:
    """``H,L,W`` (m, m, kg) or a named body, with a posture.

    Raises:
        PlannerError: the text is neither, or the body is implausible.
    """
    key = text.strip().lower()
    if key in NAMED_BODIES:
        return replace(NAMED_BODIES[key], posture=posture, seat_height_m=seat_height_m)  # type: ignore[arg-type]
    parts = [p.strip() for p in text.split(",")]
    try:
        h, span, w = (float(p) for p in parts)
    except ValueError:
        raise PlannerError(
            f"body {text!r} must be HEIGHT_M,ARM_SPAN_M,WEIGHT_KG (e.g. 1.87,1.90,80) "
            f"or one of {sorted(NAMED_BODIES)}"
        ) from None
    return BodyDimensions(h, span, w, posture, seat_height_m)  # type: ignore[arg-type]


def add_scene_args(p: argparse.ArgumentParser, receiver_required: bool = True) -> None:
    """Add the dyad's flags (bodies, postures, separation, lean, grid) to `p`."""
    p.add_argument("--receiver", required=receiver_required,
                   help="receiver body: H,L,W in m,m,kg (e.g. 1.87,1.90,80) or robot/figure3")
    p.add_argument("--giver", default="robot",
                   help="giver body: H,L,W or robot/figure3; 'robot' keeps the shoulder fixed (no lean)")
    p.add_argument("--receiver-posture", choices=["standing", "sitting"], default="standing")
    p.add_argument("--giver-posture", choices=["standing", "sitting"], default="standing")
    p.add_argument("--seat-height", type=float, default=0.45, help="seat height of a sitting actor, m")
    p.add_argument("--separation", type=float, default=1.0,
                   help="distance between where the two actors stand (thesis: 1.0 m), m")
    p.add_argument("--lean", type=float, default=None,
                   help="human shoulder lean toward the partner as a fraction of height "
                        "(default: the profile's model.lean_fraction_of_height, 0.04)")
    p.add_argument("--object-load", choices=["giver", "receiver", "both", "none"], default=None,
                   help="whose joints carry the object's weight (thesis eq 2.3: giver)")
    p.add_argument("--resolution", type=float, default=None, help="grid resolution, m")
    p.add_argument("--min-height", type=float, default=None,
                   help="lowest transfer point above the table top, m")


def config_from_args(args: argparse.Namespace) -> PlannerConfig:
    """The profile's planner config, or the defaults when no usable profile is given."""
    try:
        table = load_profile(args).service_config("planner")
    except (ProfileError, OSError, ValueError):  # missing, unreadable or invalid
        # A bus-free answer must not depend on a deploy profile; use the defaults.
        table = {}
    return load_config(table, robots.active())


def scene_from_args(args: argparse.Namespace, cfg: PlannerConfig):
    """(giver, receiver, geometry, settings) from the scene flags of `add_scene_args`.

    Raises:
        PlannerError: a body, the separation or the lean is out of range.
    """
    giver = parse_body(args.giver, args.giver_posture, args.seat_height)
    receiver = parse_body(args.receiver, args.receiver_posture, args.seat_height)
    if not (0.3 <= args.separation <= 3.0):
        raise PlannerError(f"--separation {args.separation:g} m must be within 0.3..3 m")
    lean = cfg.model.lean_fraction_of_height if args.lean is None else args.lean
    if not (0.0 <= lean <= 0.2):
        raise PlannerError(f"--lean {lean:g} must be within 0..0.2 (a fraction of height)")
    geometry = DyadGeometry(
        giver_shoulder_x_task_m=-args.separation / 2.0,
        receiver_shoulder_x_task_m=args.separation / 2.0,
        table_height_m=cfg.model.table_height_m,
        lean_fraction_of_height=lean,
        giver_is_robot=args.giver.strip().lower() == "robot",
        grasp_fraction_of_hand=cfg.model.grasp_fraction_of_hand,
    )
    settings = cfg.model.djt_settings()
    if args.object_load is not None:
        settings = replace(settings, object_load=args.object_load)
    if args.resolution is not None:
        settings = replace(settings, grid_resolution_m=args.resolution)
    if args.min_height is not None:
        settings = replace(settings, min_height_above_table_m=args.min_height)
    settings.__post_init__()  # validate the overrides
    return giver, receiver, geometry, settings


def plan_from_args(args, cfg, giver, receiver, geometry, settings, mass, spill=False) -> TransferPlan:
    """The DJT transfer plan for an object of `mass` kg (spill-sensitive: slower reach)."""
    return plan_transfer(
        giver, receiver, mass, geometry, settings, cfg.frame.frame(), timing_for(cfg),
        cfg.timing.reach_start_base_m, spill,
    )
