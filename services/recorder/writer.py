"""Writes received bus messages into one Rerun recording (.rrd), batched.

`RecordingWriter.handle(key, payload, receive_ns)` decodes one message with the topic table and
buffers it; `pump()` writes what is due:

- scalars and single 3-D points of every message go into a `ColumnBuffer` and are sent as
  Arrow record batches (one per key) every `batch_period_s` (default 0.1 s), at each
  message's own timestamps: timeline ``time`` = the sender's `stamp_ns`, timeline
  ``receive_time`` = when the recorder's Zenoh callback got it;
- Baxter's joint transforms (URDF) are batched the same way, per joint, with
  `UrdfJoint.compute_transform_columns` + `send_columns`;
- skeletons, depth images (one in `depth_every`; their numbers for every frame), text events and the review entities (`review.ReviewState`) are
  logged per message with `rr.log` (they are ≤ 30 Hz or rare);
- after each batch the file sink is flushed, so a run killed with SIGKILL loses at most the
  last `batch_period_s` of received messages (plus any backlog not yet taken from the queue).

Memory (DESIGN §9: ≤ 300 MB RSS): the file is written without Rerun's footer (chunk manifest).
With the footer, the sink keeps metadata for every chunk until the file is closed and then
builds the manifest: ~6 MB more RSS per second of recording at the stack's rates (one chunk per
entity per batch, ~3 000 chunks/s) and a spike of +130–240 MB at close. A footer-less .rrd is a
valid recording (the viewer, `rerun rrd verify` and `readback` read it in one pass); Rerun's
`rerun rrd optimize` adds a manifest afterwards if random access is wanted. See also
`rerun_env` (freed pages returned to the OS).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from services.recorder import rerun_env  # noqa: F401  (before the first `import rerun`)

import numpy as np  # noqa: E402
import rerun as rr  # noqa: E402

from bus_schema import decode, topic_for_key
from bus_schema.codec import DecodeError
from bus_schema.messages import DepthImage, JointState
from services.recorder.blueprint import blueprint, static_styles
from services.recorder.columns import TIMELINE_RECEIVE, TIMELINE_STAMP, ColumnBuffer
from services.recorder.core import event_key, message_rows
from services.recorder.review import ReviewState
from services.runtime import RateLimitedLog

log = logging.getLogger(__name__)


@dataclass
class RecorderStats:
    """Counters: messages logged per key, undecodable payloads, unknown keys, queue peak."""

    logged: dict[str, int] = field(default_factory=dict)
    rejected: int = 0
    unknown_keys: int = 0
    max_queue: int = 0


class _UrdfJoints:
    """Baxter's URDF (logged once, static) and its joint transforms, batched per joint."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        from robot_sim.baxter import urdf_path

        path = urdf_path()  # also sets ROS_PACKAGE_PATH so the meshes resolve
        rec.log_file_from_path(path, static=True)
        tree = rr.urdf.UrdfTree.from_file_path(path)
        self.robot_name = tree.name
        self.joints = {j.name: j for j in tree.joints() if j.joint_type in ("revolute", "continuous", "prismatic")}
        self._rows: dict[str, tuple[list[int], list[int], list[float]]] = {}

    def add(self, msg: JointState, receive_ns: int) -> None:
        for name, q in zip(msg.names, msg.position_rad, strict=False):
            if name in self.joints:
                stamps, receives, values = self._rows.setdefault(name, ([], [], []))
                stamps.append(msg.stamp_ns)
                receives.append(receive_ns)
                values.append(q)

    def send(self, rec: rr.RecordingStream) -> None:
        for name, (stamps, receives, values) in self._rows.items():
            rec.send_columns("transforms", indexes=_time_columns(stamps, receives),
                             columns=self.joints[name].compute_transform_columns(values, clamp=True))
        self._rows.clear()


def _time_columns(stamps_ns: list[int], receives_ns: list[int]) -> list[rr.TimeColumn]:
    return [rr.TimeColumn(TIMELINE_STAMP, timestamp=np.asarray(stamps_ns, dtype="datetime64[ns]")),
            rr.TimeColumn(TIMELINE_RECEIVE, timestamp=np.asarray(receives_ns, dtype="datetime64[ns]"))]


class RecordingWriter:
    """Decodes bus payloads and writes them to `output` (see the module docstring)."""

    def __init__(self, output: Path, prefix: str, log_urdf: bool = True, batch_period_s: float = 0.1,
                 depth_every: int = 3, application_id: str = "handover") -> None:
        output.parent.mkdir(parents=True, exist_ok=True)
        self.output = output
        self.prefix = prefix
        self.batch_period_s = batch_period_s
        self.depth_every = depth_every
        self.stats = RecorderStats()
        self.rec = rr.RecordingStream(application_id, recording_id=output.stem)
        # No footer: its per-chunk manifest grows with the recording (see the module docstring).
        self.rec.save(str(output), write_footer=False)
        # Every row carries the two timelines above; Rerun's own log_time/log_tick would only
        # exist on the rows logged one by one.
        self.rec.set_log_time_enabled(False)
        self.rec.set_log_tick_enabled(False)
        self._columns = ColumnBuffer()
        self._review = ReviewState()
        self._last_event: dict[str, tuple] = {}
        self._depth_seen = 0
        self._bad_log = RateLimitedLog(log, 1.0)
        self._urdf: _UrdfJoints | None = None
        if log_urdf:
            try:
                self._urdf = _UrdfJoints(self.rec)
            except Exception as exc:  # the recording is still useful without the meshes
                log.warning("could not log Baxter's URDF: %s", exc)
        for entity, archetype in static_styles():
            self.rec.log(entity, archetype, static=True)
        self.rec.send_blueprint(blueprint(self._urdf.robot_name if self._urdf else None))
        self.rec.flush()
        self._next_batch = time.monotonic() + batch_period_s
        self._last_stamp = (time.time_ns(), time.time_ns())  # times of the last message handled

    def handle(self, key: str, payload: bytes, receive_ns: int) -> None:
        """Decode one payload of `key` and buffer or log it (bad payloads are counted, dropped)."""
        topic = topic_for_key(key, self.prefix)
        if topic is None:
            self.stats.unknown_keys += 1
            self._bad_log.warning(f"unknown:{key}", f"recorder: no message type for key {key}")
            return
        try:
            msg = decode(topic, payload)
        except DecodeError as exc:
            self.stats.rejected += 1
            self._bad_log.warning(f"bad:{key}", f"recorder: dropped undecodable payload on {key}: {exc}")
            return
        self.stats.logged[topic.suffix] = self.stats.logged.get(topic.suffix, 0) + 1
        ekey = event_key(msg)
        fresh_event = ekey is not None and self._last_event.get(topic.suffix) != ekey
        if fresh_event:
            self._last_event[topic.suffix] = ekey
        rows = message_rows(topic, msg, log_event_text=fresh_event)
        if isinstance(msg, DepthImage):  # the numbers of every frame, the image of one in depth_every
            self._depth_seen += 1
            if (self._depth_seen - 1) % self.depth_every:
                rows.logs = [(e, a) for e, a in rows.logs if e != "camera/depth"]
        self._columns.add(topic.suffix, msg.stamp_ns, receive_ns, rows.scalars, rows.points)
        logs = rows.logs + self._review.on_message(msg)
        if logs:
            self.rec.set_time(TIMELINE_STAMP, timestamp=np.datetime64(msg.stamp_ns, "ns"))
            self.rec.set_time(TIMELINE_RECEIVE, timestamp=np.datetime64(receive_ns, "ns"))
            for entity, archetype in logs:
                self.rec.log(entity, archetype)
        if self._urdf is not None and isinstance(msg, JointState):
            self._urdf.add(msg, receive_ns)
        self._last_stamp = (msg.stamp_ns, receive_ns)

    def pump(self, force: bool = False) -> bool:
        """Write the buffered batches if the batch period is over (or `force`); True if written."""
        now = time.monotonic()
        if not force and now < self._next_batch:
            return False
        self._next_batch = now + self.batch_period_s
        for batch in self._columns.take_batches():
            self.rec.send_record_batch(batch)
        if self._urdf is not None:
            self._urdf.send(self.rec)
        path = self._review.path_update()
        if path is not None:
            stamp_ns, receive_ns = self._last_stamp
            self.rec.set_time(TIMELINE_STAMP, timestamp=np.datetime64(stamp_ns, "ns"))
            self.rec.set_time(TIMELINE_RECEIVE, timestamp=np.datetime64(receive_ns, "ns"))
            self.rec.log(*path)
        self.rec.flush()
        return True

    def close(self) -> None:
        """Write everything buffered, flush and close the file."""
        self.pump(force=True)
        self.rec.disconnect()
