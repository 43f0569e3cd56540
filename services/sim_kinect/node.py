"""Bus wiring of the simulated Kinect: joint state and sim truth in; skeleton, depth and the
Kinect's ground truth out, at `rate_hz` (30 Hz).

Each frame takes the latest `robot/joint_state` (the arm the camera sees) and, with
``scene = "handover"``, the latest `sim/truth` (the receiver's right hand and the object),
renders with `robot_sim.kinect.KinectSim` and publishes `perception/skeleton`,
`perception/depth` and `sim/kinect_truth`. Inputs may be stale: the latest one is used.
Before the first joint state nothing is rendered (the camera would show an arm that is not
there); a joint state without the arm's joints is skipped with a warning.
"""

from __future__ import annotations

import logging

from bus_schema import topics
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv
from services.sim_kinect.config import KinectConfig
from services.sim_kinect.core import TruthGate, arm_posture_rad, make_kinect_sim, scene_input

log = logging.getLogger(__name__)

SERVICE_NAME = "kinect"


def run_kinect(profile: Profile, config: KinectConfig) -> int:
    """Run the simulated Kinect until SIGINT/SIGTERM. Returns the exit code."""
    # Build the simulator (the arm's model, the body) before joining the bus: once the
    # liveliness token is up, watchdogs expect the service to be responsive.
    sim = make_kinect_sim(config) if config.enabled else None
    warn = RateLimitedLog(log, 5.0)
    frames = skipped = failed = 0
    with ServiceNode(SERVICE_NAME, profile) as node:
        # 100 Hz streams read with latest() at the 30 Hz tick: they must not wake the loop.
        joint_state = node.subscribe(topics.JOINT_STATE, queue_size=1, wake=False)
        truth = node.subscribe(topics.SIM_TRUTH, queue_size=1, wake=False)
        skeleton_pub = node.publisher(topics.SKELETON)
        depth_pub = node.publisher(topics.DEPTH)
        truth_pub = node.publisher(topics.KINECT_TRUTH)
        truth_gate = TruthGate()
        if sim is None:
            log.info("simulated Kinect disabled ([services.kinect.config] enabled = false): publishing nothing")
            while not node.should_stop:
                node.wait(1.0)
            return 0
        log.info("kinect running", extra=kv(rate_hz=config.rate_hz, scene=config.scene, posture=config.posture,
                                            height_m=config.height_m, seed=config.seed))
        waiting_logged = False
        t0: float | None = None  # the scripted reach's clock starts at the first rendered frame
        try:
            for _tick in node.loop(config.rate_hz):
                state = joint_state.latest()
                if state is None:
                    if not waiting_logged:
                        log.info("waiting for robot/joint_state before rendering")
                        waiting_logged = True
                    continue
                q = arm_posture_rad(state.msg.names, state.msg.position_rad)
                if q is None:
                    skipped += 1
                    warn.warning("joints", "joint state without the arm's joints: frame skipped",
                                 names=",".join(state.msg.names[:8]), skipped=skipped)
                    continue
                latest_truth = truth.latest()
                scene = scene_input(config.scene,
                                    None if latest_truth is None else latest_truth.msg.receiver_hand_position_m,
                                    None if latest_truth is None else latest_truth.msg.object_position_m)
                try:
                    if t0 is None:
                        t0 = node.clock.now_s()
                    frame = sim.step(node.clock.now_s() - t0, q, object_position_m=scene.object_position_m,
                                     right_hand_m=scene.right_hand_m)
                except Exception as exc:  # noqa: BLE001 - a bad frame must not kill the camera
                    failed += 1
                    warn.warning("render", f"simulated Kinect frame failed: {exc!r}", failed=failed)
                    continue
                skeleton_pub.put(**frame.skeleton_fields)
                depth_pub.put(**frame.depth_fields)
                truth_now = truth_gate.due(frame, node.clock.now_s())
                if truth_now is not None:
                    truth_pub.put(**truth_now)
                frames += 1
        finally:
            log.info("kinect stopped", extra=kv(frames=frames, skipped=skipped, failed=failed))
    return 0
