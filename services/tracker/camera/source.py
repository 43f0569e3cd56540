"""`CameraInputs`: the tracker's ``sensor = "camera"`` source (docs/camera.md).

At each tick it takes the camera thread's newest results (`services.tracker.camera.worker`),
picks the receiver among the people in view (`people.ReceiverRule`), publishes the receiver's
skeleton on `perception/skeleton` (joints with MediaPipe's visibility as confidence) and feeds
it to the pipeline with the frame's local read time. With nobody in view (or nobody in the
transfer region) it publishes and feeds a not-tracked skeleton: the pipeline reports "no
person tracked" at once. When the camera stops delivering for ``stall_s`` it warns once and
does the same every 0.1 s, so `perception/human` says not tracked and the supervisor holds;
the stack never acts on a stale skeleton (the pipeline's own ``skeleton_timeout_s`` is the
second line). Joint state comes from the bus.

Depth serves the joints only (`lift`): the pipeline gets no depth image, so Mincelli's lag
correction and the object detection do not run on this path (docs/camera.md says why). The
object's place comes from the task description, ``object_position_m``, published as the
object estimate twice a second.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from bus_schema import topics as T
from bus_schema.messages import SkeletonJoint
from services.runtime.logs import kv
from services.tracker.camera.lift import Person3D
from services.tracker.camera.people import ReceiverRule
from services.tracker.camera.worker import CameraResult, CameraWorker, Rig

log = logging.getLogger("tracker")
#: While nobody is tracked, a not-tracked skeleton goes out this often, s.
LOST_REPEAT_S = 0.1
OBJECT_REPEAT_S = 0.5


def skeleton_fields(person: Person3D) -> dict[str, Any]:
    """`Skeleton` fields (no header) of the receiver."""
    joints = [SkeletonJoint(name=name, position_m=(float(p[0]), float(p[1]), float(p[2])),  # type: ignore[arg-type]
                            confidence=min(1.0, max(0.0, person.confidence[name])))
              for name, p in person.joints_m.items()]
    return {"tracked": True, "user_id": 1, "joints": joints}


class CameraInputs:
    """The camera source (see the module docstring).

    Args:
        rig: the opened camera (`worker.open_rig`, before the node joined the bus).
        node: the tracker's open `ServiceNode`.
        object_pub: the tracker's `perception/object` publisher.
    """

    def __init__(self, rig: Rig, node: Any, object_pub: Any) -> None:
        self.rig = rig
        cfg = rig.config
        self.rule = ReceiverRule(cfg.transfer_centre_m, cfg.max_receiver_distance_m, cfg.switch_margin_m)
        self.joint_state = node.subscribe(T.JOINT_STATE, wake=False)
        self._skeleton_pub = node.publisher(T.SKELETON)
        self._object_pub = object_pub
        self._object_sent_s = -float("inf")
        self.worker = CameraWorker(rig)
        self.worker.start()
        self._start_s = time.monotonic()
        self._lost_sent_s = -float("inf")
        self._stalled = False
        self._people_seen = -1
        self.skeletons = self.nobody = 0

    def feed(self, feeder: Any, now_s: float) -> bool:
        for rx in reversed(self.joint_state.drain()):  # the newest usable one
            if feeder.joint_state(rx.msg, rx.rx_monotonic):
                break
        if now_s - self._object_sent_s >= OBJECT_REPEAT_S:
            self._object_pub.put(found=True, position_m=tuple(self.rig.config.object_position_m),
                                 size_m=(0.0, 0.0, 0.0), mass_kg=feeder.pipe.config.object_mass_kg)
            self._object_sent_s = now_s
        results = self.worker.drain()
        for result in results:
            self._feed_result(feeder, result, now_s)
        self._check_stall(feeder, now_s)
        return not (self.worker.ended.is_set() and not results)

    def _feed_result(self, feeder: Any, result: CameraResult, now_s: float) -> None:
        index = self.rule.choose([p.torso_m for p in result.people])
        count = len(result.people)
        if count != self._people_seen:
            log.info("camera: %s", "nobody in view" if result.found_2d == 0 else
                     f"{count} person(s) in view" + ("" if index is not None else ", none in the transfer region"),
                     extra=kv(frame=result.frame.index, switches=self.rule.switches))
            self._people_seen = count
        if index is None:
            self.nobody += 1
            self._send_lost(feeder, now_s, result.rx_s)
            return
        msg = self._skeleton_pub.put(**skeleton_fields(result.people[index]))
        feeder.skeleton(msg, result.rx_s)
        self.skeletons += 1

    def _send_lost(self, feeder: Any, now_s: float, t_s: float) -> None:
        if now_s - self._lost_sent_s < LOST_REPEAT_S:
            return
        msg = self._skeleton_pub.put(tracked=False, user_id=0, joints=[])
        feeder.skeleton(msg, t_s)  # the pipeline reports the loss now, not after its timeout
        self._lost_sent_s = now_s

    def _check_stall(self, feeder: Any, now_s: float) -> None:
        last = self.worker.last_frame_s
        silent_s = now_s - (self._start_s if last is None else last)
        if silent_s <= self.rig.config.stall_s:
            if self._stalled:
                log.info("camera delivers frames again")
            self._stalled = False
            return
        if not self._stalled and not self.worker.ended.is_set():
            log.warning(f"camera {self.rig.config.input}: no frame for {silent_s:.1f} s: the receiver counts as "
                        "lost (is the camera connected, or used by another program?)")
            self._stalled = True
        self.rule.reset()
        self._send_lost(feeder, now_s, now_s)

    def stats(self) -> dict[str, float]:
        return {**self.worker.summary(), "skeletons": self.skeletons, "nobody": self.nobody,
                "receiver_switches": self.rule.switches}

    def close(self) -> None:
        self.worker.stop()
        self.worker.join(timeout=2.0)
        self.rig.close()
