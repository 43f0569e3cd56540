"""`handover-planner`: the DJT planner service, and answers without a bus.

    handover-planner [--profile sim] [run]              # the service on the bus
    handover-planner plan --receiver 1.87,1.90,80 --object-mass 0.2 [--giver robot] [--figure F]
    handover-planner experiment --receiver 1.75,1.76,70 --receiver-posture sitting

Bodies are ``HEIGHT_M,ARM_SPAN_M,WEIGHT_KG`` or a name: ``robot`` (190 cm, 200 cm, 100 kg,
thesis §2.5) or ``figure3`` (187 cm, 190 cm, 80 kg, thesis Fig. 3).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from services.planner.anthropometrics import FIGURE3_ACTOR, ROBOT_AS_HUMAN, BodyDimensions
from services.planner.config import PlannerConfig, load_config
from services.planner.core import timing_for
from services.planner.errors import PlannerError
from services.planner.experiment import EMPTY_CUP_KG, FULL_CUP_KG, four_positions, heavy_light_positions
from services.planner.transfer_plan import DyadGeometry, TransferPlan, plan_transfer
from services.runtime import ProfileError, base_parser, load_profile, run_main

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


def _add_scene_args(p: argparse.ArgumentParser, receiver_required: bool = True) -> None:
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


def build_parser() -> argparse.ArgumentParser:
    parser = base_parser("handover-planner", "DJT planner: where to hand the object over (thesis §2.2–2.5)")
    sub = parser.add_subparsers(dest="command", metavar="{run,plan,experiment}")
    sub.add_parser("run", help="run the planner service on the bus (the default)")
    plan = sub.add_parser("plan", help="answer for given bodies without a bus")
    _add_scene_args(plan)
    plan.add_argument("--object-mass", type=float, default=EMPTY_CUP_KG, help="object mass, kg")
    plan.add_argument("--spill-sensitive", action="store_true",
                      help="a spill-sensitive object (full cup): slower reach")
    plan.add_argument("--figure", type=Path, default=None, help="save the cost-map figure (PNG)")
    plan.add_argument("--json", action="store_true", help="print the answer as JSON")
    exp = sub.add_parser("experiment", help="the candidate positions of the human–robot experiment (§2.5.1)")
    _add_scene_args(exp)
    exp.add_argument("--json", action="store_true", help="print the answer as JSON")
    return parser


def _config(args: argparse.Namespace) -> PlannerConfig:
    try:
        table = load_profile(args).service_config("planner")
    except (ProfileError, OSError, ValueError):  # missing, unreadable or invalid
        # A bus-free answer must not depend on a deploy profile; use the defaults.
        table = {}
    return load_config(table)


def _scene(args: argparse.Namespace, cfg: PlannerConfig):
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


def _plan(args, cfg, giver, receiver, geometry, settings, mass, spill=False) -> TransferPlan:
    return plan_transfer(
        giver, receiver, mass, geometry, settings, cfg.frame.frame(), timing_for(cfg),
        cfg.timing.reach_start_base_m, spill,
    )


def _plan_summary(plan: TransferPlan) -> dict:
    o = plan.optimum
    g, r = plan.dyad.giver, plan.dyad.receiver
    return {
        "position_task_m": [round(v, 4) for v in plan.position_task_m],
        "position_base_m": [round(v, 4) for v in plan.position_base_m],
        "cost_n2m2": round(plan.cost, 3),
        "active_constraints": plan.active_constraints,
        "giver_torque_nm": [round(v, 3) for v in o.giver_torque_nm],
        "receiver_torque_nm": [round(v, 3) for v in o.receiver_torque_nm],
        "giver_shoulder_task_m": [round(g.shoulder_x_m, 4), round(g.shoulder_z_m, 4)],
        "receiver_shoulder_task_m": [round(r.shoulder_x_m, 4), round(r.shoulder_z_m, 4)],
        "giver_links_m": [round(g.arm.upper_arm_m, 4), round(g.arm.forearm_to_grasp_m, 4)],
        "receiver_links_m": [round(r.arm.upper_arm_m, 4), round(r.arm.forearm_to_grasp_m, 4)],
        "reach_distance_m": round(plan.reach.distance_m, 4),
        "reach_duration_s": round(plan.reach.duration_s, 4),
        "peak_speed_m_s": round(plan.reach.peak_speed_m_s, 4),
        "object_mass_kg": plan.object_mass_kg,
    }


def cmd_plan(args: argparse.Namespace) -> int:
    cfg = _config(args)
    giver, receiver, geometry, settings = _scene(args, cfg)
    plan = _plan(args, cfg, giver, receiver, geometry, settings, args.object_mass, args.spill_sensitive)
    if args.figure is not None:
        from services.planner.figures import draw_plan  # matplotlib only when asked
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.4, 5.0))
        draw_plan(ax, plan, f"giver {args.giver} ({giver.posture}), receiver {args.receiver} "
                            f"({receiver.posture}), object {args.object_mass:g} kg")
        fig.tight_layout()
        try:
            fig.savefig(args.figure, dpi=120)
        except OSError as exc:
            raise PlannerError(f"cannot write the figure to {args.figure}: {exc}") from None
        finally:
            plt.close(fig)
    summary = _plan_summary(plan)
    if args.json:
        print(json.dumps(summary))
        return 0
    x, z = plan.position_task_m
    bx, by, bz = plan.position_base_m
    o = plan.optimum
    print(f"transfer point, task plane : x = {x * 100:+.1f} cm (+ toward the receiver), "
          f"z = {z * 100:.1f} cm above the table top")
    print(f"transfer point, base frame : ({bx:.3f}, {by:.3f}, {bz:.3f}) m")
    print(f"E_DJT                      : {plan.cost:.2f} N² m²; active constraints: "
          f"{', '.join(plan.active_constraints) or 'none'}")
    print(f"giver    τ (shoulder, elbow): ({o.giver_torque_nm[0]:.2f}, {o.giver_torque_nm[1]:.2f}) N m; "
          f"links {summary['giver_links_m']} m; shoulder at {summary['giver_shoulder_task_m']} m")
    print(f"receiver τ (shoulder, elbow): ({o.receiver_torque_nm[0]:.2f}, {o.receiver_torque_nm[1]:.2f}) N m; "
          f"links {summary['receiver_links_m']} m; shoulder at {summary['receiver_shoulder_task_m']} m")
    print(f"reach                      : {plan.reach.distance_m:.3f} m in {plan.reach.duration_s:.2f} s, "
          f"peak {plan.reach.peak_speed_m_s:.2f} m/s (minimum jerk)")
    if args.figure is not None:
        print(f"cost map                   : {args.figure}")
    return 0


def cmd_experiment(args: argparse.Namespace) -> int:
    cfg = _config(args)
    giver, receiver, geometry, settings = _scene(args, cfg)
    frame = cfg.frame.frame()
    light = _plan(args, cfg, giver, receiver, geometry, settings, EMPTY_CUP_KG)
    task = "task 2 (receiver sitting)" if receiver.posture == "sitting" else "task 1 (receiver standing)"
    rows = {task: four_positions(light, settings, frame)}
    heavy = _plan(args, cfg, giver, receiver, geometry, settings, FULL_CUP_KG, spill=True)
    rows["tasks 3/4 (full cup 335 g vs empty cup 65 g)"] = heavy_light_positions(heavy, light, settings, frame)
    if args.json:
        print(json.dumps({k: [vars(c) | {"cost": c.cost if c.feasible else None} for c in v]
                          for k, v in rows.items()}))
        return 0
    for title, cands in rows.items():
        print(title)
        for c in cands:
            x, z = c.position_task_m
            b = ", ".join(f"{v:.3f}" for v in c.position_base_m)
            cost = f"{c.cost:7.1f}" if c.feasible else "unreachable"
            print(f"  {c.name}: task ({x * 100:+6.1f}, {z * 100:5.1f}) cm  base ({b}) m  "
                  f"E_DJT {cost}  {c.description}")
    return 0


def _dispatch(args: argparse.Namespace) -> int:
    if args.command == "plan":
        return cmd_plan(args)
    if args.command == "experiment":
        return cmd_experiment(args)
    from services.planner.node import run

    return run(args)


def main(argv: list[str] | None = None) -> int:
    """Entry point of `handover-planner` (exit 0 ok, 1 failure, 2 bad input)."""
    args = build_parser().parse_args(argv)
    return run_main(_dispatch, args, service="planner")
