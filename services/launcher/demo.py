"""The joint-space demo job: drive the arm through a few waypoints and check it followed.

Until the supervisor exists this is what `handover-up` runs by default. Each segment is a
jerk-limited Ruckig trajectory (at half the arm's velocity limits) streamed as joint commands
at 100 Hz; the job then compares the measured joint state with the commands.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
from ruckig import InputParameter, Result, Ruckig, Trajectory

from bus_schema import topics
from handover_model import robots
from handover_model.robots import arm_model
from services.runtime import RateLoop, ServiceNode

log = logging.getLogger(__name__)

#: Offsets from the home posture (rad), visited in order, then home again.
DEMO_OFFSETS_RAD: tuple[tuple[float, ...], ...] = (
    (0.45, 0.0, 0.0, -0.35, 0.0, 0.30, 0.0),
    (-0.35, 0.15, 0.3, 0.0, 0.2, -0.2, 0.5),
    (0.0,) * 7,
)
COMMAND_RATE_HZ = 100.0
#: The demo's waypoints stay this far inside the joint limits, rad.
DEMO_LIMIT_MARGIN_RAD = 0.05


@dataclass
class DemoResult:
    """Outcome of the demo.

    Attributes:
        ok: the arm followed (final error below tolerance) and nothing failed.
        duration_s: time spent streaming commands, s.
        commands_sent: joint commands published.
        max_tracking_error_rad: largest |measured − commanded| seen while moving, rad.
        final_error_rad: largest |measured − final target| after settling, rad.
        tool_path_length_m: length of the measured tool path, m.
        message: one line on failure.
    """

    ok: bool
    duration_s: float = 0.0
    commands_sent: int = 0
    max_tracking_error_rad: float = 0.0
    final_error_rad: float = float("inf")
    tool_path_length_m: float = 0.0
    message: str = ""
    lines: list[str] = field(default_factory=list)


def plan_segment(start_rad: np.ndarray, goal_rad: np.ndarray, speed_fraction: float = 0.5) -> Trajectory:
    """Jerk-limited joint trajectory from rest to rest (Ruckig)."""
    limits = arm_model().limits
    otg = Ruckig(len(start_rad))
    inp = InputParameter(len(start_rad))
    inp.current_position = list(start_rad)
    inp.current_velocity = [0.0] * len(start_rad)
    inp.current_acceleration = [0.0] * len(start_rad)
    inp.target_position = list(goal_rad)
    inp.target_velocity = [0.0] * len(start_rad)
    inp.target_acceleration = [0.0] * len(start_rad)
    inp.max_velocity = list(limits.velocity_rad_s * speed_fraction)
    inp.max_acceleration = [2.0] * len(start_rad)
    inp.max_jerk = [10.0] * len(start_rad)
    trajectory = Trajectory(len(start_rad))
    result = otg.calculate(inp, trajectory)
    if result not in (Result.Working, Result.Finished):
        raise RuntimeError(f"Ruckig could not plan the demo segment: {result}")
    return trajectory


def run_demo(node: ServiceNode, abort: callable, settle_s: float = 0.6,
             tolerance_rad: float = 0.01) -> DemoResult:
    """Run the demo on `node`'s bus. `abort()` returning a reason string stops it early."""
    states = node.subscribe(topics.JOINT_STATE)
    commands = node.publisher(topics.JOINT_COMMAND)
    deadline = time.monotonic() + 5.0
    while states.latest() is None:
        if time.monotonic() > deadline:
            return DemoResult(False, message="no joint state from the bridge within 5 s")
        if (reason := abort()) or node.should_stop:
            return DemoResult(False, message=reason or "interrupted")
        node.wait(0.05)
    arm = robots.active()
    home = np.array(arm.home_rad)
    current = np.array(states.latest().msg.position_rad)
    model = arm_model()
    lo, hi = model.limits.lower_rad + DEMO_LIMIT_MARGIN_RAD, model.limits.upper_rad - DEMO_LIMIT_MARGIN_RAD
    # The offsets are the first joints' for a shorter arm, kept within the joint limits.
    waypoints = [np.clip(home + np.array(o[:arm.dof]), lo, hi) for o in DEMO_OFFSETS_RAD]
    result = DemoResult(False)
    period = 1.0 / COMMAND_RATE_HZ
    t_start = time.monotonic()
    last_tool = model.tool_pose(current)[0]
    for index, goal in enumerate(waypoints):
        trajectory = plan_segment(current, goal)
        log.info("demo segment %d/%d: %.2f s", index + 1, len(waypoints), trajectory.duration)
        for tick in RateLoop(COMMAND_RATE_HZ, node.stop_event, name="demo command"):
            t = min(tick * period, trajectory.duration)
            position, _velocity, _acc = trajectory.at_time(t)
            commands.put(names=list(arm.joints), position_rad=list(position), goal_id=f"demo-{index}")
            result.commands_sent += 1
            latest = states.latest()
            if latest is not None:
                measured = np.array(latest.msg.position_rad)
                # Servo lag: compare with the command of about one servo time constant ago.
                lagged, _, _ = trajectory.at_time(max(0.0, t - 0.06))
                result.max_tracking_error_rad = max(result.max_tracking_error_rad,
                                                    float(np.max(np.abs(measured - np.array(lagged)))))
                tool = model.tool_pose(measured)[0]
                result.tool_path_length_m += float(np.linalg.norm(tool - last_tool))
                last_tool = tool
            if (reason := abort()) or node.should_stop:
                result.message = reason or "interrupted"
                return result
            if t >= trajectory.duration:
                break
        current = goal
    # Keep commanding the final posture while the servo settles.
    settle_end = time.monotonic() + settle_s
    for _tick in RateLoop(COMMAND_RATE_HZ, node.stop_event, name="demo settle"):
        if time.monotonic() >= settle_end:
            break
        commands.put(names=list(arm.joints), position_rad=list(current), goal_id="demo-settle")
        result.commands_sent += 1
    result.duration_s = time.monotonic() - t_start
    latest = states.latest()
    result.final_error_rad = float(np.max(np.abs(np.array(latest.msg.position_rad) - current)))
    result.ok = result.final_error_rad <= tolerance_rad
    if not result.ok:
        result.message = (f"arm did not reach the final posture: error {result.final_error_rad:.4f} rad "
                          f"> {tolerance_rad} rad")
    result.lines = [
        f"demo: {len(waypoints)} jerk-limited joint moves in {result.duration_s:.2f} s, "
        f"{result.commands_sent} joint commands at {COMMAND_RATE_HZ:.0f} Hz",
        f"tool path {result.tool_path_length_m:.3f} m; max tracking error "
        f"{result.max_tracking_error_rad:.4f} rad; final error {result.final_error_rad:.5f} rad",
    ]
    return result
