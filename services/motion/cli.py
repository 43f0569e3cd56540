"""`handover-motion`: the motion service, and a one-shot planner that needs no bus.

    handover-motion [--profile sim]             run the service (default)
    handover-motion plan --to X Y Z [...]       plan one goal offline, print (and plot) it
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from handover_model import robots, scene
from services.motion.config import MotionConfig
from services.motion.errors import MotionError
from services.runtime import ServiceError, base_parser, load_profile, run_main
from services.runtime.cli import HelpFormatter


class MotionCliError(ServiceError):
    """Bad input to `handover-motion` (one-line reason, exit code 2)."""

    bad_input = True


def _config(args: argparse.Namespace) -> MotionConfig:
    profile = load_profile(args)
    try:
        return MotionConfig.from_dict(profile.service_config("motion"), robots.active())
    except MotionError as exc:
        raise MotionCliError(str(exc)) from exc


def _run_service(args: argparse.Namespace) -> int:
    from services.motion.node import run_motion

    profile = load_profile(args)
    return run_motion(profile, _config(args))


def _vector(values: list[float] | None, n: int, name: str) -> tuple[float, ...] | None:
    if values is None:
        return None
    if len(values) != n or not all(np.isfinite(values)):
        raise MotionCliError(f"{name} needs {n} finite numbers, got {values}")
    return tuple(float(v) for v in values)


def _plan(args: argparse.Namespace) -> int:
    from bus_schema.messages import MotionGoal
    from services.motion.core import MotionController
    from services.motion.ik import ArmIk
    from services.motion.preview import preview

    import logging

    if args.log_level != "debug":  # one-shot mode: the result is printed, not logged
        logging.getLogger("services.motion.core").setLevel(logging.WARNING)
    config = _config(args)
    position = _vector(args.to, 3, "--to")
    if args.to_task is not None:
        task = _vector(args.to_task, 2, "--to-task")
        position = tuple(float(v) for v in scene.task_to_base(np.array(task)))
    arm = robots.active()
    start = np.array(_vector(args.from_joints, arm.dof, "--from-joints") or arm.home_rad)
    if args.duration < 0 or args.peak_speed < 0:
        raise MotionCliError("--duration and --peak-speed must be >= 0")
    try:
        goal = MotionGoal(
            seq=0, stamp_ns=0, source="cli", goal_id="cli", kind=args.kind,
            position_base_m=position,
            joint_target_rad=list(_vector(args.joints, arm.dof, "--joints") or []),
            duration_s=args.duration, peak_speed_m_s=args.peak_speed,
            receiver_hand_position_m=_vector(args.hand, 3, "--hand"),
        )
    except (TypeError, ValueError) as exc:
        raise MotionCliError(f"invalid goal: {exc}") from exc
    controller = MotionController(config, ArmIk(config))
    record = preview(controller, goal, start)
    status = record.final_status
    if status.state != "reached":
        raise MotionCliError(f"goal {status.state}: {status.reason}")
    speed = record.tool_speed_m_s
    print(f"{args.kind} goal reached: planned {record.planned_duration_s:.3f} s, "
          f"{len(record.time_s)} commands at {config.rate_hz:g} Hz, "
          f"peak tool speed {speed.max():.3f} m/s")
    p_end, r_end = controller.ik.tool_pose(record.q_rad[-1])
    print(f"final tool position (base, m): {np.round(p_end, 4).tolist()}")
    z_axis = r_end[:, 2]
    print(f"final approach axis (base): {np.round(z_axis, 4).tolist()}")
    names = " ".join(f"{n.removeprefix('right_')[-7:]:>7}" for n in arm.joints)
    print(f"{'t_s':>6} {'x_m':>7} {'y_m':>7} {'z_m':>7} {'v_m_s':>6} {names}")
    step = max(1, int(round(args.every / config.period_s)))
    rows = list(range(0, len(record.time_s), step))
    if rows[-1] != len(record.time_s) - 1:
        rows.append(len(record.time_s) - 1)
    for i in rows:
        q = " ".join(f"{v:7.3f}" for v in record.q_rad[i])
        x, y, z = record.tool_m[i]
        print(f"{record.time_s[i]:6.2f} {x:7.3f} {y:7.3f} {z:7.3f} {speed[i]:6.3f} {q}")
    if args.plot:
        from services.motion.plot import plot_record

        plot_record(record, args.plot, title=f"{args.kind} to {np.round(p_end, 3).tolist()}")
        print(f"plot written to {args.plot}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = base_parser(
        "handover-motion",
        "Motion service: PlaCo IK + Ruckig for the profile's arm ([robot], docs/robots.md). "
        "Without a subcommand it runs "
        "the service (goals and stops in, joint commands at 100 Hz while moving, and status out); "
        "`plan` plans one goal offline and prints the joint trajectory.",
    )
    sub = parser.add_subparsers(dest="command", metavar="{run,plan}")
    sub.add_parser("run", help="run the service on the bus (the default)")
    plan = sub.add_parser(
        "plan", help="plan one goal without the bus and print (or plot) the trajectory",
        formatter_class=HelpFormatter,
    )
    plan.add_argument("--kind", choices=["transfer", "pick", "retract", "joint"], default="transfer",
                      help="transfer: minimum-jerk Cartesian reach; others: Ruckig joint moves")
    plan.add_argument("--to", type=float, nargs=3, metavar=("X", "Y", "Z"),
                      help="target tool position in the base frame, m")
    plan.add_argument("--to-task", type=float, nargs=2, metavar=("X", "Z"),
                      help="target in the task plane (x toward the receiver, z up from the table top), m")
    plan.add_argument("--joints", type=float, nargs="+", metavar="Q",
                      help="joint target (kind joint/retract), rad, one per arm joint")
    plan.add_argument("--from-joints", type=float, nargs="+", metavar="Q",
                      help="start joints, rad, one per arm joint (default: the home posture)")
    plan.add_argument("--duration", type=float, default=0.0, help="duration, s (0: from speed)")
    plan.add_argument("--peak-speed", type=float, default=0.0, help="peak tool speed, m/s (0: default)")
    plan.add_argument("--hand", type=float, nargs=3, metavar=("X", "Y", "Z"),
                      help="receiver's hand, base frame, m (0.25 m/s cap within 0.3 m)")
    plan.add_argument("--every", type=float, default=0.1, help="print one row every this many s")
    plan.add_argument("--plot", default=None, help="write a PNG of the trajectory here")
    args = parser.parse_args(argv)
    run = _plan if args.command == "plan" else _run_service
    return run_main(run, args, service="motion")


if __name__ == "__main__":
    sys.exit(main())
