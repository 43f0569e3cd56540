"""`handover-planner`: the DJT planner service, and answers without a bus.

    handover-planner [--profile sim] [run]              # the service on the bus
    handover-planner plan --receiver 1.87,1.90,80 --object-mass 0.2 [--giver robot] [--figure F]
    handover-study experiment --receiver 1.75,1.76,70 --receiver-posture sitting

Bodies are ``HEIGHT_M,ARM_SPAN_M,WEIGHT_KG`` or a name: ``robot`` (190 cm, 200 cm, 100 kg,
thesis §2.5) or ``figure3`` (187 cm, 190 cm, 80 kg, thesis Fig. 3).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from services.planner.transfer_plan import TransferPlan
from services.planner.errors import PlannerError
from services.planner.scene_args import (
    EMPTY_CUP_KG,
    add_scene_args,
    config_from_args,
    plan_from_args,
    scene_from_args,
)
from services.runtime import base_parser, run_main


def build_parser() -> argparse.ArgumentParser:
    parser = base_parser("handover-planner", "DJT planner: where to hand the object over (thesis §2.2–2.5)")
    sub = parser.add_subparsers(dest="command", metavar="{run,plan}")
    sub.add_parser("run", help="run the planner service on the bus (the default)")
    plan = sub.add_parser("plan", help="answer for given bodies without a bus")
    add_scene_args(plan)
    plan.add_argument("--object-mass", type=float, default=EMPTY_CUP_KG, help="object mass, kg")
    plan.add_argument("--spill-sensitive", action="store_true",
                      help="a spill-sensitive object (full cup): slower reach")
    plan.add_argument("--figure", type=Path, default=None, help="save the cost-map figure (PNG)")
    plan.add_argument("--json", action="store_true", help="print the answer as JSON")
    return parser


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
    cfg = config_from_args(args)
    giver, receiver, geometry, settings = scene_from_args(args, cfg)
    plan = plan_from_args(args, cfg, giver, receiver, geometry, settings, args.object_mass, args.spill_sensitive)
    if args.figure is not None:
        import matplotlib.pyplot as plt

        from services.planner.plot import draw_plan  # matplotlib only when asked

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


def _dispatch(args: argparse.Namespace) -> int:
    if args.command == "plan":
        return cmd_plan(args)
    from services.planner.node import run

    return run(args)


def main(argv: list[str] | None = None) -> int:
    """Entry point of `handover-planner` (exit 0 ok, 1 failure, 2 bad input)."""
    args = build_parser().parse_args(argv)
    return run_main(_dispatch, args, service="planner")
