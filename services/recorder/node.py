"""Bus wiring of the recorder: everything under ``<prefix>/**`` into one .rrd per run.

The Zenoh callback only enqueues (key, payload, receive time); the main thread decodes with
the topic table and logs to Rerun at each message's own timestamp (timeline ``time`` =
sender's `stamp_ns`; Rerun adds ``log_time``). The file sink is flushed every
`flush_period_s`, so a run killed with SIGTERM — or even SIGKILL — leaves a readable file up
to the last flush; on SIGTERM/SIGINT the recorder drains the queue and flushes before exit.
"""

from __future__ import annotations

import logging
import queue
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
import zenoh

from bus_schema import decode, topic_for_key
from bus_schema.codec import DecodeError
from bus_schema.messages import DepthImage, JointState
from services.recorder.core import event_key, to_rerun
from services.runtime import Profile, RateLimitedLog, ServiceNode, kv

log = logging.getLogger(__name__)

SERVICE_NAME = "recorder"


@dataclass
class RecorderStats:
    """Counters: messages logged per key, undecodable payloads, unknown keys."""

    logged: dict[str, int] = field(default_factory=dict)
    rejected: int = 0
    unknown_keys: int = 0
    max_queue: int = 0


class _UrdfJoints:
    """Joint transforms of Baxter's URDF, computed by Rerun's own URDF tree."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        from robot_sim.baxter import urdf_path

        path = urdf_path()  # also sets ROS_PACKAGE_PATH so the meshes resolve
        rec.log_file_from_path(path, static=True)
        tree = rr.urdf.UrdfTree.from_file_path(path)
        self.robot_name = tree.name
        self.joints = {j.name: j for j in tree.joints() if j.joint_type in ("revolute", "continuous", "prismatic")}

    def log(self, rec: rr.RecordingStream, msg: JointState) -> None:
        for name, q in zip(msg.names, msg.position_rad, strict=False):
            joint = self.joints.get(name)
            if joint is not None:
                rec.log("transforms", joint.compute_transform(q, clamp=True))


def _blueprint(robot_name: str | None) -> rrb.Blueprint:
    overrides = {f"{robot_name}/collision_geometries": rrb.EntityBehavior(visible=False)} if robot_name else {}
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name="Robot and scene", origin="/", overrides=overrides),
            rrb.Vertical(
                rrb.TimeSeriesView(name="Joint positions (rad)", origin="/robot/joint_position"),
                rrb.TimeSeriesView(name="Wrist force (N)", origin="/bus/sensors/wrist_wrench"),
                rrb.TimeSeriesView(name="Grip force (N)", origin="/bus/gripper"),
                rrb.TextLogView(name="Events", origin="/events"),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


def default_output_path(directory: Path, run_id: str) -> Path:
    return directory / f"handover-{run_id}.rrd"


def run_recorder(profile: Profile, output: Path, log_urdf: bool = True,
                 flush_period_s: float = 0.25, application_id: str = "handover",
                 depth_every: int = 3) -> int:
    """Record the bus into `output` until SIGINT/SIGTERM.

    Depth images (150 kB each at 30 Hz) are logged one in `depth_every` to keep recordings
    small; every other message is logged.
    """
    output.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream(application_id, recording_id=output.stem)
    rec.save(str(output))
    stats = RecorderStats()
    bad_log = RateLimitedLog(log, 1.0)
    inbox: queue.SimpleQueue[tuple[str, bytes]] = queue.SimpleQueue()
    last_event: dict[str, tuple] = {}
    depth_seen = [0]

    def on_sample(sample: zenoh.Sample) -> None:  # Zenoh thread: enqueue only
        inbox.put((str(sample.key_expr), sample.payload.to_bytes()))

    def handle(key: str, payload: bytes) -> None:
        topic = topic_for_key(key, profile.prefix)
        if topic is None:
            stats.unknown_keys += 1
            bad_log.warning(f"unknown:{key}", f"recorder: no message type for key {key}")
            return
        try:
            msg = decode(topic, payload)
        except DecodeError as exc:
            stats.rejected += 1
            bad_log.warning(f"bad:{key}", f"recorder: dropped undecodable payload on {key}: {exc}")
            return
        if isinstance(msg, DepthImage):
            depth_seen[0] += 1
            if (depth_seen[0] - 1) % depth_every:
                stats.logged[topic.suffix] = stats.logged.get(topic.suffix, 0) + 1
                return
        rec.set_time("time", timestamp=np.datetime64(msg.stamp_ns, "ns"))
        ekey = event_key(msg)
        fresh_event = ekey is not None and last_event.get(topic.suffix) != ekey
        if fresh_event:
            last_event[topic.suffix] = ekey
        for entity, archetype in to_rerun(topic, msg, log_event_text=fresh_event):
            rec.log(entity, archetype)
        if urdf is not None and isinstance(msg, JointState):
            urdf.log(rec, msg)
        stats.logged[topic.suffix] = stats.logged.get(topic.suffix, 0) + 1

    urdf = None
    with ServiceNode(SERVICE_NAME, profile) as node:
        # Subscribe first: messages queue up while the 3-D model loads.
        subscriber = node.session.declare_subscriber(f"{profile.prefix}/**", on_sample)
        if log_urdf:
            try:
                urdf = _UrdfJoints(rec)
            except Exception as exc:  # the recording is still useful without the meshes
                log.warning("could not log Baxter's URDF: %s", exc)
        rec.send_blueprint(_blueprint(urdf.robot_name if urdf else None))
        rec.flush()
        log.info("recording", extra=kv(output=str(output), keys=f"{profile.prefix}/**"))
        next_flush = time.monotonic() + flush_period_s
        try:
            while not node.should_stop:
                try:
                    key, payload = inbox.get(timeout=0.05)
                except queue.Empty:
                    key = None
                if key is not None:
                    handle(key, payload)
                    backlog = inbox.qsize()
                    stats.max_queue = max(stats.max_queue, backlog)
                now = time.monotonic()
                if now >= next_flush:
                    rec.flush()
                    next_flush = now + flush_period_s
        finally:
            subscriber.undeclare()
            while True:  # drain what arrived before the subscriber closed
                try:
                    key, payload = inbox.get_nowait()
                except queue.Empty:
                    break
                handle(key, payload)
            rec.flush()
            rec.disconnect()
            total = sum(stats.logged.values())
            log.info("recording closed", extra=kv(output=str(output), messages=total,
                                                 rejected=stats.rejected, max_queue=stats.max_queue))
    return 0
