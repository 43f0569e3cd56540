"""Motion service + bridge sim backend as real processes on a loopback bus.

- A transfer goal: the arm reaches the pose, checked from the bridge's JointState through
  pinocchio forward kinematics (independent of the motion service's PlaCo model).
- A MotionStop mid-reach: time from the stop's publication to the arm at rest in JointState
  (every joint below `REST_SPEED_RAD_S`), over repeated runs; reported, and bounded loosely
  (the DESIGN target of 50 ms is not met with the sim servo's lag, see docs/motion.md).
"""

from __future__ import annotations

import json
import os
import time

import numpy as np
import pytest

from bus_schema import topics
from handover_model import scene
from handover_model.robots import baxter
from services.runtime.testing import ServiceProcess, wait_alive, wait_until

pytestmark = pytest.mark.integration

#: A joint speed below this counts as at rest (rad/s); 0.01 rad/s moves the tool < 1 cm/s.
REST_SPEED_RAD_S = 0.01
TARGETS = [
    tuple(scene.task_to_base(np.array([0.05, 0.35]))),
    tuple(scene.task_to_base(np.array([-0.15, 0.10]))),
]
STOP_RUNS = int(os.environ.get("MOTION_STOP_RUNS", "6"))


@pytest.fixture
def stack(bus):
    profile, router = bus
    with ServiceProcess("services.bridge", profile) as bridge, \
            ServiceProcess("services.motion", profile) as motion:
        try:
            wait_alive(router, profile, {"bridge", "motion"}, timeout_s=30.0)
        except TimeoutError:
            raise AssertionError(f"not alive; motion log:\n{motion.log_text()}\nbridge log:\n{bridge.log_text()}")
        yield profile, bridge, motion


def _status_until(statuses, goal_id, states, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for rx in statuses.drain():
            if rx.msg.goal_id == goal_id and rx.msg.state in states:
                return rx.msg
        time.sleep(0.002)
    return None


def test_reaches_a_transfer_pose_and_a_stop_halts_it(stack, make_node):
    profile, bridge, motion = stack
    node = make_node()
    goals = node.publisher(topics.MOTION_GOAL)
    stops = node.publisher(topics.MOTION_STOP)
    statuses = node.subscribe(topics.MOTION_STATUS, queue_size=4096)
    states = node.subscribe(topics.JOINT_STATE, queue_size=4096)
    assert wait_until(lambda: states.latest() is not None, 10.0)
    time.sleep(0.3)  # let the motion service see joint states
    arm = baxter.arm_model()

    # 1. Reach: transfer goal from the home posture, then check FK of the measured joints.
    goals.put(goal_id="reach", kind="transfer", position_base_m=TARGETS[0])
    final = _status_until(statuses, "reach", {"reached", "failed"}, 15.0)
    assert final is not None, f"no final status; motion log:\n{motion.log_text()[-3000:]}"
    assert final.state == "reached", final.reason
    time.sleep(0.3)
    q = np.array(states.latest().msg.position_rad)
    p, r = arm.tool_pose(q)
    error_m = float(np.linalg.norm(p - np.array(TARGETS[0])))
    assert error_m <= 2e-3, f"tool {error_m * 1000:.2f} mm from the transfer pose"
    assert float(np.degrees(np.arccos(np.clip(-r[2, 2], -1, 1)))) <= 1.0  # approach axis down

    # 2. Stops mid-reach, alternating between two targets.
    latencies, speeds_at_stop = [], []
    for run in range(STOP_RUNS):
        goal_id = f"stop{run}"
        target = TARGETS[(run + 1) % 2]
        statuses.drain()
        goals.put(goal_id=goal_id, kind="transfer", position_base_m=target)
        moving = _status_until(statuses, goal_id, {"moving", "failed"}, 5.0)
        assert moving is not None and moving.state == "moving"
        # Wait until mid-reach (progress 40 %: near the minimum-jerk speed peak).
        mid = None
        deadline = time.monotonic() + 3.0
        while mid is None and time.monotonic() < deadline:
            mid = next((rx for rx in statuses.drain() if rx.msg.goal_id == goal_id
                        and rx.msg.progress >= 0.4), None)
            time.sleep(0.001)
        assert mid is not None, "never reached mid-reach"
        speed_before = max(abs(v) for v in states.latest().msg.velocity_rad_s)
        states.drain()
        t_stop = time.monotonic()
        stops.put(reason="release")
        rest_at = None
        deadline = t_stop + 2.0
        while time.monotonic() < deadline and rest_at is None:
            for rx in states.drain():
                if rx.rx_monotonic > t_stop and max(abs(v) for v in rx.msg.velocity_rad_s) < REST_SPEED_RAD_S:
                    rest_at = rx.rx_monotonic
                    break
            time.sleep(0.0005)
        assert rest_at is not None, "arm did not come to rest within 2 s of the stop"
        latencies.append(rest_at - t_stop)
        speeds_at_stop.append(speed_before)
        stopped = _status_until(statuses, goal_id, {"stopped"}, 1.0)
        assert stopped is not None and "release" in stopped.reason
        # It stays put: no motion over the next 0.3 s although the goal was not finished.
        q_rest = np.array(states.latest().msg.position_rad)
        time.sleep(0.3)
        q_later = np.array(states.latest().msg.position_rad)
        assert np.abs(q_later - q_rest).max() < 0.005
        assert np.linalg.norm(arm.tool_pose(q_later)[0] - np.array(target)) > 0.02
    lat_ms = np.array(latencies) * 1000
    summary = {
        "runs": len(lat_ms),
        "rest_speed_rad_s": REST_SPEED_RAD_S,
        "stop_to_rest_ms_p50": float(np.percentile(lat_ms, 50)),
        "stop_to_rest_ms_p99": float(np.percentile(lat_ms, 99)),
        "stop_to_rest_ms_max": float(lat_ms.max()),
        "joint_speed_at_stop_rad_s_median": float(np.median(speeds_at_stop)),
        "reach_error_mm": error_m * 1000,
    }
    print("\nmotion stop → arm at rest (JointState):", json.dumps(summary, indent=1))
    # DESIGN §8 asks for p99 ≤ 50 ms; with the sim's first-order servo (τ = 50 ms) the measured
    # p99 was ~150–250 ms before the bridge honoured feed-forward, ~80 ms now (docs/motion.md). This
    # bound catches a stop that does not act at all (a coasting arm would need the rest of the reach,
    # ~0.7 s).
    assert summary["stop_to_rest_ms_p99"] <= 350.0, summary
