"""The one table of the bus: key → message type, and how each key is published.

The recorder, the fuzz tests and the docs all read `TOPICS`. A key expression is
``<prefix>/<suffix>``; the default prefix carries the schema version (`handover/v1`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from bus_schema import messages as m

SCHEMA_VERSION = 1
DEFAULT_PREFIX = f"handover/v{SCHEMA_VERSION}"
ALIVE_SUFFIX = "alive"

#: ``safety`` keys are published with congestion control BLOCK and a high priority;
#: ``state`` keys may be dropped under congestion; ``clock`` keys carry the simulation clock
#: (on which every key is sent at one priority and never dropped, so that on every link a clock
#: message follows whatever its sender put on the bus before it: `services.runtime.clock`).
Delivery = Literal["safety", "state", "clock"]


@dataclass(frozen=True)
class Topic:
    """One key of the bus.

    Attributes:
        suffix: key below the prefix, e.g. ``robot/joint_state``.
        type: the msgspec Struct carried on this key (exactly one).
        delivery: ``safety`` (BLOCK, high priority) or ``state`` (may drop).
        nominal_rate_hz: expected publication rate (0: on events only), for freshness checks
            and docs.
        publisher: the service that publishes it.
        description: one line for the docs.
        per_sender: each sender publishes on its own key, ``<prefix>/<suffix>/<sender>``
            (`sender_key`), so that the bus's access control can grant a key to one service
            and a reader knows the sender from the key (issue 17); readers subscribe to
            ``<prefix>/<suffix>/*`` (`key`). A message's ``source`` must name the key's sender.
    """

    suffix: str
    type: type[m.Message]
    delivery: Delivery
    nominal_rate_hz: float
    publisher: str
    description: str
    per_sender: bool = False

    def key(self, prefix: str = DEFAULT_PREFIX) -> str:
        """Full key expression under `prefix` (for a `per_sender` topic, the one that
        matches every sender's key)."""
        return f"{prefix}/{self.suffix}/*" if self.per_sender else f"{prefix}/{self.suffix}"

    def sender_key(self, sender: str, prefix: str = DEFAULT_PREFIX) -> str:
        """The key `sender` publishes on: its own below a `per_sender` topic, else `key`."""
        return f"{prefix}/{self.suffix}/{sender}" if self.per_sender else self.key(prefix)


_T = Topic
JOINT_STATE = _T("robot/joint_state", m.JointState, "state", 100, "bridge", "measured arm joints")
JOINT_COMMAND = _T("robot/joint_command", m.JointCommand, "safety", 100, "motion", "arm joint targets")
WRIST_WRENCH = _T("sensors/wrist_wrench", m.WristWrench, "state", 100, "bridge", "wrist F/T, gripper frame")
OBJECT_MOTION = _T("sensors/object_motion", m.ObjectMotion, "state", 100, "bridge", "optical slip sensor")
SKELETON = _T("perception/skeleton", m.Skeleton, "state", 30, "bridge", "15-joint skeleton")
DEPTH = _T("perception/depth", m.DepthImage, "state", 30, "bridge", "depth image")
HUMAN = _T("perception/human", m.HumanState, "state", 30, "tracker", "corrected receiver state")
OBJECT = _T("perception/object", m.ObjectEstimate, "state", 30, "tracker", "object on the table")
TRANSFER = _T("planner/transfer", m.TransferTarget, "state", 5, "planner", "DJT transfer point")
MOTION_GOAL = _T("motion/goal", m.MotionGoal, "safety", 0, "supervisor", "motion goals")
MOTION_STATUS = _T("motion/status", m.MotionStatus, "state", 50, "motion", "motion progress")
MOTION_STOP = _T("motion/stop", m.MotionStop, "safety", 0, "supervisor", "release/protective stop (also the "
                "launcher, and the bridge when the supervisor dies mid-episode)")
GRIPPER_COMMAND = _T("gripper/command", m.GripperCommand, "safety", 100, "gripper", "grip force command")
GRIPPER_STATE = _T("gripper/state", m.GripperState, "state", 100, "gripper", "gripper mode and force")
GRIPPER_RELEASE = _T("gripper/release", m.ReleaseEvent, "safety", 0, "gripper", "release event")
SUPERVISOR_STATE = _T("supervisor/state", m.SupervisorState, "state", 10, "supervisor", "handover phase")
EPISODE = _T("supervisor/episode", m.EpisodeSummary, "state", 0, "supervisor", "episode summary")
HEARTBEAT = _T("runtime/heartbeat", m.Heartbeat, "state", 10, "every service", "process running (20 Hz across hosts)",
               per_sender=True)
SIM_TRUTH = _T("sim/truth", m.SimTruth, "state", 100, "bridge", "simulator ground truth (10 Hz at rest)")
KINECT_TRUTH = _T("sim/kinect_truth", m.KinectTruth, "state", 30, "tracker or kinect", "body truth (10 Hz still)")
CLOCK = _T("sim/clock", m.ClockGrant, "clock", 0, "bridge", "simulation clock step, on sim/clock/<participant>")
CLOCK_READY = _T("sim/clock_ready", m.ClockReady, "clock", 0, "every clock participant",
                 "done with a step, next step wanted (sim clock only)", per_sender=True)
del _T

TOPICS: tuple[Topic, ...] = (
    JOINT_STATE,
    JOINT_COMMAND,
    WRIST_WRENCH,
    OBJECT_MOTION,
    SKELETON,
    DEPTH,
    HUMAN,
    OBJECT,
    TRANSFER,
    MOTION_GOAL,
    MOTION_STATUS,
    MOTION_STOP,
    GRIPPER_COMMAND,
    GRIPPER_STATE,
    GRIPPER_RELEASE,
    SUPERVISOR_STATE,
    EPISODE,
    HEARTBEAT,
    SIM_TRUTH,
    KINECT_TRUTH,
    CLOCK,
    CLOCK_READY,
)
TOPICS_BY_SUFFIX: dict[str, Topic] = {t.suffix: t for t in TOPICS}
assert len(TOPICS_BY_SUFFIX) == len(TOPICS), "duplicate key in TOPICS"
assert len({t.type for t in TOPICS}) == len(TOPICS), "one key, one type: a type is reused"


def alive_key(service: str, prefix: str = DEFAULT_PREFIX) -> str:
    """Liveliness token key of `service`."""
    return f"{prefix}/{ALIVE_SUFFIX}/{service}"


def topic_for_key(key: str, prefix: str = DEFAULT_PREFIX) -> Topic | None:
    """The topic whose full key is `key` under `prefix` (a sender's own key of a
    `per_sender` topic included), or None."""
    head = prefix + "/"
    if not key.startswith(head):
        return None
    suffix = key[len(head) :]
    topic = TOPICS_BY_SUFFIX.get(suffix)
    if topic is not None:
        return None if topic.per_sender else topic
    parent, _, sender = suffix.rpartition("/")
    topic = TOPICS_BY_SUFFIX.get(parent)
    return topic if topic is not None and topic.per_sender and sender_name_ok(sender) else None


def sender_of_key(key: str) -> str:
    """The sender named by the last chunk of a `per_sender` topic's key."""
    return key.rpartition("/")[2]


def sender_name_ok(name: str) -> bool:
    """A sender (service) name usable as one key chunk: non-empty, no wildcard or separator."""
    return bool(name) and not any(c in name for c in "/*$?#")
