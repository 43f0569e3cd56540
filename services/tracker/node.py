"""Bus wiring of the tracker: skeleton, depth and joint state in; human state and object out.

Live (``sensor = "bus"``): subscribes `perception/skeleton`, `perception/depth`,
`robot/joint_state`. Simulation (``sensor = "sim"``): renders the simulated Kinect in this
process from `robot/joint_state` and `sim/truth` (`services.tracker.sources`). Replay: reads a
replay file instead, paced in real time, and publishes the same outputs, so the tracker runs
without the simulator. Publishes `perception/human` on every skeleton frame
(and at 10 Hz when frames stop coming, with ``tracked = False``) and `perception/object`
whenever an object detection runs: at full rate while the newest `supervisor/state` wants
the object (`core.object_wanted`), at the rest rate otherwise.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from bus_schema import topics as T
from handover_model import robots
from handover_model.robot_geometry import ArmGeometry
from services.runtime import ServiceNode
from services.runtime.clock import SimClock
from services.runtime.logs import RateLimitedLog, kv
from services.runtime.profile import Profile
from services.tracker.config import TrackerConfig
from services.tracker.core import HumanEstimate, TrackerPipeline, object_wanted, skeleton_frame_from_message
from services.tracker.objects import ObjectDetection
from services.tracker.pointcloud import DepthFrame, depth_frame_from_message
from services.tracker.process import tune_process
from services.tracker.ros1.calibration import CameraPose, load_calibration
from services.tracker.sources import BusInputs, ReplayInputs, SimKinectInputs

log = logging.getLogger("tracker")
HEARTBEAT_S = 0.1


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def human_fields(est: HumanEstimate) -> dict:
    """`HumanState` fields (no header) of an estimate."""
    return {
        "tracked": est.tracked,
        "hand_position_m": _vec(est.hand_m),
        "hand_raw_position_m": _vec(est.hand_raw_m),
        "correction": est.correction,
        "torso_position_m": _vec(est.torso_m),
        "height_m": est.body.height_m,
        "arm_span_m": est.body.arm_span_m,
        "shoulder_height_m": est.body.shoulder_height_m,
        "posture": est.body.posture,
        "weight_kg": est.weight_kg,
        "frame_age_s": min(est.frame_age_s, 86400.0),
    }


def object_fields(det: ObjectDetection, mass_kg: float) -> dict:
    """`ObjectEstimate` fields (no header) of a detection."""
    if not det.found:
        return {"found": False, "mass_kg": mass_kg}
    return {
        "found": True,
        "position_m": _vec(det.position_m),
        "size_m": tuple(float(max(0.0, s)) for s in det.size_m),
        "mass_kg": mass_kg,
    }


class _Feeder:
    """Feeds messages into the pipeline and remembers what changed."""

    def __init__(self, pipe: TrackerPipeline) -> None:
        self.pipe = pipe
        self.warnings = RateLimitedLog(log, 5.0)
        self.human: list[HumanEstimate] = []

    def joint_state(self, msg, t_s: float) -> bool:
        """Feed a joint state; False (and a warning) when it lacks the arm's joints."""
        index = {n: i for i, n in enumerate(msg.names)}
        joints = robots.active().joints
        if any(n not in index for n in joints) or len(msg.position_rad) != len(msg.names):
            self.warnings.warning("joint_state", "joint_state without the arm's joints: ignored")
            return False
        self.pipe.on_joint_state(np.array([msg.position_rad[index[n]] for n in joints]), t_s)
        return True

    def depth(self, msg, t_s: float) -> None:
        try:
            self.pipe.on_depth(depth_frame_from_message(msg, t_s))
        except ValueError as exc:  # e.g. a zero-norm or inconsistent camera pose
            self.warnings.warning("depth", f"depth image ignored: {exc}")

    def depth_frame(self, frame: DepthFrame) -> None:
        """A depth frame made in this process (the simulated Kinect's: no message to decode)."""
        self.pipe.on_depth(frame)

    def new_person(self) -> None:
        """The receiver is another person from now on (`TrackerPipeline.new_person`)."""
        self.pipe.new_person()

    def skeleton(self, msg, t_s: float) -> None:
        self.human.append(self.pipe.on_skeleton(skeleton_frame_from_message(msg, t_s)))


def ros1_calibration(profile: Profile, config: TrackerConfig) -> CameraPose:
    """The ROS 1 camera's calibration (``ros1.calibration_file``, relative to the profile's folder).

    Raises:
        CalibrationError: the file is missing or invalid (one line).
    """
    path = Path(config.ros1.calibration_file).expanduser()
    if not path.is_absolute():
        path = (profile.path.parent if profile.path is not None else Path.cwd()) / path
    return load_calibration(path, config.ros1.skeleton_frame_id)


def _inputs(node: ServiceNode, config: TrackerConfig, replay_path: Path | None, replay_loop: bool,
            pose: CameraPose | None, rig=None, object_pub=None):
    """The tick's input source: a replay file, the in-process simulated Kinect, the ROS 1
    Kinect, a camera or the bus."""
    if rig is not None:
        from services.tracker.camera.source import CameraInputs

        return CameraInputs(rig, node, object_pub)
    if replay_path is not None:
        return ReplayInputs(replay_path, replay_loop, node.clock.now_s())
    if config.sensor == "sim":
        return SimKinectInputs(config.sim_kinect, node, config.publish_depth)
    if config.sensor == "ros1" and pose is not None:
        from services.tracker.ros1.source import Ros1KinectInputs

        return Ros1KinectInputs(config.ros1, pose, node, config.publish_depth)
    return BusInputs(node)


def run_node(profile: Profile, config: TrackerConfig, replay_path: Path | None = None,
             replay_loop: bool = False) -> int:
    """Run the tracker until shutdown (or the end of the replay file)."""
    # A missing or invalid calibration stops the start here, before the node joins the bus.
    pose = ros1_calibration(profile, config) if config.sensor == "ros1" and replay_path is None else None
    rig = None
    if config.sensor == "camera" and replay_path is None:  # no camera, file or model: stop here too
        from services.tracker.camera.worker import open_rig

        rig = open_rig(config.camera, profile.path.parent if profile.path is not None else Path.cwd())
    log.info("process: %s", tune_process())
    arm = ArmGeometry()
    pipe = TrackerPipeline(config, arm)
    feeder = _Feeder(pipe)
    with ServiceNode("tracker", profile) as node:
        human_pub = node.publisher(T.HUMAN)
        object_pub = node.publisher(T.OBJECT)
        # Read at each tick (never wakes the loop): the phase says whether anyone reads the object.
        supervisor_state = node.subscribe(T.SUPERVISOR_STATE, queue_size=1, wake=False)
        inputs = _inputs(node, config, replay_path, replay_loop, pose, rig, object_pub)
        rate_hz = config.sim_kinect.rate_hz if isinstance(inputs, SimKinectInputs) else config.rate_hz
        log.info("tracker inputs: %s", "replay" if replay_path is not None else config.sensor,
                 extra=kv(rate_hz=rate_hz))
        last_publish = 0.0
        last_status = None
        clock = node.clock
        for _tick in node.loop(rate_hz):
            if isinstance(clock, SimClock) and config.sim_clock_latency_s > 0.0:
                clock.answer_early(config.sim_clock_latency_s)  # the clock steps on while this frame is computed
            now = node.clock.now_s()
            state_rx = supervisor_state.latest()
            pipe.set_object_wanted(object_wanted(state_rx.msg.phase if state_rx else None,
                                                 now - state_rx.rx_monotonic if state_rx else 0.0))
            ended = not inputs.feed(feeder, now)  # a replay's end: its last frames still count
            det = pipe.detect_object()
            if det is not None:
                object_pub.put(**object_fields(det, config.object_mass_kg))
            if feeder.human or now - last_publish >= HEARTBEAT_S:
                feeder.human.clear()
                state = pipe.human_state(now)
                human_pub.put(**human_fields(state))
                last_publish = now
                status = (state.tracked, state.status)
                if status != last_status:
                    log.info("human %s%s", "tracked" if state.tracked else "not tracked",
                             f": {state.status}" if state.status else "")
                    last_status = status
            if ended:
                node.request_stop()
                break
        if isinstance(inputs, SimKinectInputs):
            log.info("simulated Kinect stopped", extra=kv(frames=inputs.frames, skipped=inputs.skipped,
                                                          failed=inputs.failed))
        elif hasattr(inputs, "stats"):  # the ROS 1 Kinect or the camera
            inputs.close()
            log.info("%s stopped", "camera" if rig is not None else "ROS 1 Kinect", extra=kv(**inputs.stats()))
    return 0
