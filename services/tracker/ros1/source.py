"""`Ros1KinectInputs`: the tracker's ``sensor = "ros1"`` source (docs/kinect_ros1.md).

The camera side runs openni_launch + openni_tracker under ROS 1 and zenoh-bridge-ros1, which
carries ``/tf``, the depth image and its camera info as raw ROS 1 bytes on the keys of
`services.bridge.baxter.keys.topic_key` (the Baxter backend's mapping). This source
subscribes those keys on the tracker's session: the Zenoh callbacks only decode (typed,
bounded; a payload that does not decode is counted and dropped, never raised) and queue; at
each tick it

- assembles openni_tracker's joint transforms into frames (`skeleton.SkeletonAssembler`,
  out-of-order joints dropped and counted), converts them into `base` with the calibration,
  picks the receiver among the users (`skeleton.ReceiverChooser`; when it changes, the
  pipeline forgets the previous person), publishes the receiver's frame on
  `perception/skeleton` and feeds it to the pipeline; while no frame of the receiver comes it
  publishes a not-tracked skeleton every 0.1 s (the pipeline reports the loss on
  `perception/human` after its ``skeleton_timeout_s``, and the supervisor holds);
- converts the newest depth image with the newest camera info (`depth.depth_fields`), feeds it
  (and publishes it on `perception/depth` with ``publish_depth``).

Joint state comes from the bus as for ``sensor = "bus"``. Freshness is judged by local receive
times; sender stamps only order the frames.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from typing import Any

import zenoh

from bus_schema import topics as T
from bus_schema.messages import SKELETON_JOINTS, SkeletonJoint
from services.bridge.baxter.keys import topic_key
from services.bridge.baxter.ros1 import Ros1DecodeError, Ros1Message
from services.runtime.logs import RateLimitedLog, kv
from services.tracker.ros1.calibration import CameraPose
from services.tracker.ros1.config import Ros1KinectConfig
from services.tracker.ros1.depth import DepthConversionError, depth_fields
from services.tracker.ros1.messages import CameraInfo, Image, TFMessage
from services.tracker.ros1.skeleton import ReceiverChooser, SkeletonAssembler, UserFrame, joint_samples

log = logging.getLogger("tracker")
#: While the receiver is lost, a not-tracked skeleton goes out this often, s.
LOST_REPEAT_S = 0.1


class RosInbox:
    """Decoded messages of one ROS 1 key with their local receive times (Zenoh thread in,
    tick thread out; bounded: the oldest go first)."""

    def __init__(self, cls: type[Ros1Message], key: str, keep: int) -> None:
        self.cls, self.key = cls, key
        self.received = self.rejected = 0
        self.last_rx_s: float | None = None
        self._queue: deque[tuple[Any, float]] = deque(maxlen=keep)
        self._lock = threading.Lock()
        self._bad_log = RateLimitedLog(log, 5.0)

    def on_sample(self, sample: zenoh.Sample) -> None:
        """Zenoh callback: decode and queue; nothing escapes into Zenoh's thread."""
        try:
            msg = self.cls.from_bytes(sample.payload.to_bytes())
        except Ros1DecodeError as exc:
            self.rejected += 1
            self._bad_log.warning(self.key, f"dropped undecodable {self.cls.TYPE} on {self.key}: {exc}",
                                  rejected=self.rejected)
            return
        except Exception as exc:  # noqa: BLE001 - a Zenoh callback: nothing may escape into Zenoh's thread
            self.rejected += 1
            self._bad_log.warning(self.key, f"dropped payload on {self.key}: {exc!r}", rejected=self.rejected)
            return
        rx_s = time.monotonic()
        with self._lock:
            self._queue.append((msg, rx_s))
            self.received += 1
            self.last_rx_s = rx_s

    def drain(self) -> list[tuple[Any, float]]:
        with self._lock:
            out = list(self._queue)
            self._queue.clear()
        return out


def skeleton_fields(frame: UserFrame) -> dict[str, Any]:
    """`bus_schema.messages.Skeleton` fields (no header) of a user's frame (`base`, m)."""
    joints = [SkeletonJoint(name=name, position_m=(float(p[0]), float(p[1]), float(p[2])))
              for name, p in zip(SKELETON_JOINTS, frame.joints_m, strict=True)]
    return {"tracked": True, "user_id": frame.user, "joints": joints}


class Ros1KinectInputs:
    """The ROS 1 Kinect source (see the module docstring).

    Args:
        config: ``[services.tracker.config.ros1]``.
        pose: the calibration (camera frame → `base`), loaded before the node opened.
        node: the tracker's open `ServiceNode`.
        publish_depth: also publish `perception/depth`.
    """

    def __init__(self, config: Ros1KinectConfig, pose: CameraPose, node: Any, publish_depth: bool = False) -> None:
        self.config = config

        def key(topic: str, cls: type[Ros1Message]) -> str:
            return topic_key(topic, cls.TYPE, config.key_format, config.key_namespace)

        t = config.topics
        self.tf = RosInbox(TFMessage, key(t.tf, TFMessage), keep=4096)
        self.image = RosInbox(Image, key(t.depth_image, Image), keep=2)
        self.info = RosInbox(CameraInfo, key(t.camera_info, CameraInfo), keep=2)
        self._subs = [node.session.declare_subscriber(box.key, box.on_sample) for box in (self.tf, self.image,
                                                                                          self.info)]
        self.joint_state = node.subscribe(T.JOINT_STATE, wake=False)
        self._skeleton_pub = node.publisher(T.SKELETON)
        self._depth_pub = node.publisher(T.DEPTH) if publish_depth else None
        self.pose = pose
        self.assembler = SkeletonAssembler(pose, config.frame_spread_s)
        self.chooser = ReceiverChooser(config.transfer_centre_m, config.max_receiver_distance_m,
                                       config.switch_margin_m, config.user_lost_s)
        self._camera_info: CameraInfo | None = None
        self._image_stamp_ns = -1
        self._start_s = time.monotonic()
        self._receiver_rx_s: float | None = None
        self._frame_rx_s: float | None = None  # the last complete frame of any user
        self._lost_sent_s = -float("inf")
        self._warned: set[str] = set()
        self._warn = RateLimitedLog(log, 5.0)
        self.skeletons = self.depth_frames = self.bad_transforms = self.depth_dropped = self.depth_out_of_order = 0

    # ------------------------------------------------------------------ per tick
    def feed(self, feeder: Any, now_s: float) -> bool:
        for rx in reversed(self.joint_state.drain()):  # the newest usable one
            if feeder.joint_state(rx.msg, rx.rx_monotonic):
                break
        self._feed_skeleton(feeder, now_s)
        self._feed_depth(feeder)
        self._check_silence(now_s)
        return True

    def _feed_skeleton(self, feeder: Any, now_s: float) -> None:
        for msg, rx_s in self.tf.drain():
            samples, bad = joint_samples(msg, self.config.skeleton_frame_id, rx_s)
            if bad:
                self.bad_transforms += bad
                self._warn.warning("frame", f"joint transforms not relative to {self.config.skeleton_frame_id!r} "
                                   "or not finite: ignored (set [services.tracker.config.ros1] skeleton_frame_id "
                                   "to openni_tracker's camera_frame_id)", ignored=self.bad_transforms)
            for sample in samples:
                self.assembler.add(sample)
        previous = self.chooser.receiver
        frames = self.assembler.complete()
        if frames:
            self._frame_rx_s = max(f.rx_s for f in frames)
        chosen = self.chooser.choose(frames, now_s, self.assembler.pending(now_s))
        for user in self.chooser.forgotten(now_s):
            self.assembler.forget(user)
        self.assembler.prune(now_s, self.config.user_lost_s)
        if self.chooser.receiver != previous:
            if self.chooser.receiver is not None:
                feeder.new_person()  # no torso, speed or body window carried over from someone else
            log.info("receiver: %s", "none in the transfer region" if self.chooser.receiver is None
                     else f"user {self.chooser.receiver}", extra=kv(switches=self.chooser.switches))
        if chosen is not None:
            msg = self._skeleton_pub.put(**skeleton_fields(chosen))
            feeder.skeleton(msg, chosen.rx_s)
            self.skeletons += 1
            self._receiver_rx_s = chosen.rx_s
        elif (self._receiver_rx_s is None or now_s - self._receiver_rx_s > LOST_REPEAT_S) \
                and now_s - self._lost_sent_s >= LOST_REPEAT_S:
            self._skeleton_pub.put(tracked=False, user_id=0, joints=[])  # for the recorder: nobody tracked
            self._lost_sent_s = now_s

    def _feed_depth(self, feeder: Any) -> None:
        infos = self.info.drain()
        if infos:
            self._camera_info = infos[-1][0]
        images = self.image.drain()
        if not images:
            return
        image, rx_s = images[-1]
        self.depth_dropped += len(images) - 1  # older than the newest: the pipeline keeps one
        stamp_ns = image.header.stamp.to_ns()
        problem = None
        if image.header.frame_id.lstrip("/") != self.config.depth_frame_id.lstrip("/"):
            problem = (f"depth image in frame {image.header.frame_id!r}, expected {self.config.depth_frame_id!r} "
                       "([services.tracker.config.ros1] depth_frame_id)")
        elif stamp_ns <= self._image_stamp_ns:
            self.depth_out_of_order += 1
            problem = "depth image older than the previous one: dropped"
        elif self._camera_info is None:
            problem = f"no camera_info yet on {self.info.key}: depth image dropped"
        if problem is None:
            try:
                fields = depth_fields(image, self._camera_info, self.pose)  # type: ignore[arg-type]
            except DepthConversionError as exc:
                problem = str(exc)
        if problem is not None:
            self.depth_dropped += 1
            self._warn.warning("depth", problem, dropped=self.depth_dropped)
            return
        self._image_stamp_ns = stamp_ns
        if self._depth_pub is not None:
            msg = self._depth_pub.put(**fields)
        else:
            msg = T.DEPTH.type(seq=self.depth_frames, stamp_ns=time.time_ns(), source="tracker", **fields)
        self.depth_frames += 1
        feeder.depth(msg, rx_s)

    def _check_silence(self, now_s: float) -> None:
        """One warning per silent spell of the skeleton or the depth image."""
        limit = self.config.no_data_warning_s
        for name, box, what in (("skeleton", self.tf, "is openni_tracker running and publishing /tf, and is "
                                 "/tf bridged by zenoh-bridge-ros1"),
                                ("depth", self.image, "is openni_launch running and the depth image bridged")):
            last = self._frame_rx_s if name == "skeleton" else box.last_rx_s
            silent_s = now_s - (self._start_s if last is None else last)
            if silent_s > limit and name not in self._warned:
                self._warned.add(name)
                log.warning(f"no {name} from the camera on {box.key} for {silent_s:.1f} s: {what} "
                            "(docs/kinect_ros1.md)?")
            elif silent_s <= limit:
                self._warned.discard(name)

    def stats(self) -> dict[str, int]:
        return {"skeletons": self.skeletons, "frames": self.assembler.frames,
                "out_of_order": self.assembler.out_of_order, "bad_transforms": self.bad_transforms,
                "tf_rejected": self.tf.rejected, "depth_frames": self.depth_frames,
                "depth_dropped": self.depth_dropped, "depth_out_of_order": self.depth_out_of_order,
                "image_rejected": self.image.rejected, "receiver_switches": self.chooser.switches}

    def close(self) -> None:
        for sub in self._subs:
            try:
                sub.undeclare()
            except Exception:  # noqa: BLE001 - best-effort close: the session may be closing
                pass
        self._subs = []
