"""openni_tracker's skeleton from ``/tf``: joint transforms → whole frames per user → the receiver.

openni_tracker broadcasts, for each tracked user and each of the 15 OpenNI joints, one
transform ``<camera_frame_id> → <joint>_<user>`` (e.g. ``openni_depth_frame → right_hand_1``),
one `sendTransform` each, about 30 times a second; the translation is the joint's position
in the camera frame (x forward, y left, z up, m). The orientation is not used.

- `joint_samples`: the skeleton joints of one ``TFMessage`` (other transforms ignored).
- `SkeletonAssembler`: a user's frame is complete when all 15 joints arrived since the
  user's previous frame, stamped within ``frame_spread_s`` of each other; positions go into
  `base` with the calibration. A joint stamped no later than the one already held, or than
  the user's last frame, is out of order: dropped and counted.
- `ReceiverChooser`: which user is the receiver (the rule is in its docstring).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from bus_schema.messages import SKELETON_JOINTS
from services.tracker.ros1.calibration import CameraPose
from services.tracker.ros1.messages import TFMessage

_CHILD = re.compile(rf"^/?({'|'.join(SKELETON_JOINTS)})_(\d{{1,5}})$")
_INDEX: dict[str, int] = {name: i for i, name in enumerate(SKELETON_JOINTS)}
#: A joint farther than this from the camera is a bad value, not a person, m.
MAX_JOINT_RANGE_M = 20.0
#: The largest user id taken (`bus_schema.messages.Skeleton.user_id`'s bound).
MAX_USER_ID = 65535
#: A user whose joints are arriving but whose first frame has not completed yet holds the choice
#: of a receiver for at most this long, s: the tracker may subscribe in the middle of a frame, and
#: the nearest user's first frame must not lose the choice to a farther user's whole one.
FIRST_FRAME_WAIT_S = 0.2


@dataclass(frozen=True)
class JointSample:
    """One joint transform: the user's id, the joint's name, the stamp (ns, sender's clock),
    the position (3,) in the camera frame (m) and the local receive time (s, monotonic)."""

    user: int
    joint: str
    stamp_ns: int
    position_m: tuple[float, float, float]
    rx_s: float


def joint_samples(msg: TFMessage, frame_id: str, rx_s: float) -> tuple[list[JointSample], int]:
    """The skeleton joints of `msg` relative to `frame_id`, and how many of its transforms
    named a joint but were unusable (another parent frame, a value not finite or absurd)."""
    out: list[JointSample] = []
    bad = 0
    frame = frame_id.lstrip("/")
    for tf in msg.transforms:
        match = _CHILD.match(tf.child_frame_id)
        if match is None:
            continue  # the robot's and anything else's frames share /tf
        t = tf.transform.translation
        p = (float(t.x), float(t.y), float(t.z))
        if tf.header.frame_id.lstrip("/") != frame or not math.hypot(*p) <= MAX_JOINT_RANGE_M:  # NaN fails too
            bad += 1
            continue
        user = int(match.group(2))
        if user > MAX_USER_ID:  # the bus's user_id bound (openni_tracker counts from 1)
            bad += 1
            continue
        out.append(JointSample(user, match.group(1), tf.header.stamp.to_ns(), p, rx_s))
    return out, bad


@dataclass(frozen=True)
class UserFrame:
    """One complete skeleton frame of one user.

    Attributes:
        user: openni_tracker's user id.
        stamp_ns: the newest joint stamp (sender's clock, ns).
        rx_s: when its last joint arrived (local monotonic s).
        joints_m: (15, 3) joint positions in `base`, m, in `SKELETON_JOINTS` order.
    """

    user: int
    stamp_ns: int
    rx_s: float
    joints_m: np.ndarray

    @property
    def torso_m(self) -> np.ndarray:
        return self.joints_m[_INDEX["torso"]]


@dataclass
class _User:
    stamps_ns: np.ndarray = field(default_factory=lambda: np.full(len(SKELETON_JOINTS), -1, np.int64))
    positions_m: np.ndarray = field(default_factory=lambda: np.zeros((len(SKELETON_JOINTS), 3)))
    emitted_ns: int = -1
    rx_s: float = -np.inf
    first_rx_s: float = np.inf


class SkeletonAssembler:
    """Joint samples in, complete frames in `base` out (see the module docstring).

    Args:
        pose: the calibration (camera frame → `base`).
        spread_s: the joints of one frame are stamped within this of each other, s.
    """

    def __init__(self, pose: CameraPose, spread_s: float) -> None:
        self.pose = pose
        self.spread_ns = int(spread_s * 1e9)
        self._users: dict[int, _User] = {}
        self.out_of_order = 0
        self.frames = 0

    def add(self, sample: JointSample) -> None:
        user = self._users.setdefault(sample.user, _User())
        i = _INDEX[sample.joint]
        if sample.stamp_ns <= user.stamps_ns[i] or sample.stamp_ns <= user.emitted_ns:
            self.out_of_order += 1
            return
        user.stamps_ns[i] = sample.stamp_ns
        user.positions_m[i] = sample.position_m
        user.rx_s = max(user.rx_s, sample.rx_s)
        user.first_rx_s = min(user.first_rx_s, sample.rx_s)

    def pending(self, now_s: float, wait_s: float = FIRST_FRAME_WAIT_S) -> list[int]:
        """Users with joints but no complete frame yet, first heard within `wait_s` (s) of
        `now_s` (local s): who may still turn out to be the receiver."""
        return [uid for uid, user in self._users.items()
                if user.emitted_ns < 0 and now_s - user.first_rx_s <= wait_s]

    def complete(self) -> list[UserFrame]:
        """The users whose frame completed since the last call, in user-id order."""
        out = []
        for uid in sorted(self._users):
            user = self._users[uid]
            first, last = int(user.stamps_ns.min()), int(user.stamps_ns.max())
            if first <= user.emitted_ns or last - first > self.spread_ns:
                continue
            user.emitted_ns = last
            self.frames += 1
            joints = self.pose.to_base(user.positions_m)
            joints.flags.writeable = False
            out.append(UserFrame(uid, last, user.rx_s, joints))
        return out

    def forget(self, user: int) -> None:
        """Drop a user's state (openni_tracker lost them; a new user may reuse the id)."""
        self._users.pop(user, None)

    def prune(self, now_s: float, lost_s: float) -> list[int]:
        """Forget users with no joint for `lost_s` (s) at `now_s` (local s): a user whose
        frames never complete is not kept for ever. Returns their ids."""
        gone = [uid for uid, user in self._users.items() if now_s - user.rx_s > lost_s]
        for uid in gone:
            del self._users[uid]
        return gone


class ReceiverChooser:
    """The receiver among the users in view, stable across frames.

    Rule: only users whose torso is within `max_distance_m` (horizontally, the x-y plane of
    `base`) of the transfer region's centre can be the receiver. The receiver stays the same
    user while it is seen; another user takes over when the receiver has not been seen for
    `lost_s`, or when that user is nearer the centre by more than `margin_m`. With no
    receiver, the nearest candidate (the lower id on a tie) becomes it, but not while a user
    whose first frame is still arriving (`SkeletonAssembler.pending`) might be nearer.

    Args:
        centre_m: (3,) the transfer region's centre, m, `base`.
    """

    def __init__(self, centre_m: Sequence[float] | np.ndarray, max_distance_m: float, margin_m: float,
                 lost_s: float) -> None:
        self.centre_xy = np.asarray(centre_m, float)[:2]
        self.max_distance_m = max_distance_m
        self.margin_m = margin_m
        self.lost_s = lost_s
        self.receiver: int | None = None
        self.switches = 0
        self._seen: dict[int, tuple[float, float]] = {}  # user → (distance m, last frame rx s)

    def distance_m(self, frame: UserFrame) -> float:
        """Horizontal distance of the user's torso from the transfer centre, m."""
        return float(np.linalg.norm(frame.torso_m[:2] - self.centre_xy))

    def forgotten(self, now_s: float) -> list[int]:
        """Forget users not seen for `lost_s`; returns their ids."""
        gone = [u for u, (_, rx_s) in self._seen.items() if now_s - rx_s > self.lost_s]
        for user in gone:
            del self._seen[user]
        if self.receiver in gone:
            self.receiver = None
        return gone

    def choose(self, frames: list[UserFrame], now_s: float, pending: Sequence[int] = ()) -> UserFrame | None:
        """Update with this tick's complete frames; the receiver's frame, if it has a new one.
        `pending`: users whose first frame is still arriving; with no receiver yet, nobody is
        chosen while there are any (the caller bounds how long a user stays pending)."""
        for f in frames:
            self._seen[f.user] = (self.distance_m(f), f.rx_s)
        self.forgotten(now_s)
        candidates = {u: d for u, (d, _) in self._seen.items() if d <= self.max_distance_m}
        if self.receiver is not None and self.receiver not in candidates:
            self.receiver = None  # walked out of the region
        if self.receiver is None and any(u not in self._seen for u in pending):
            return None  # a nearer user's first frame may be half-way in
        if candidates:
            best = min(sorted(candidates), key=lambda u: candidates[u])
            if self.receiver is None or candidates[best] < candidates[self.receiver] - self.margin_m:
                if best != self.receiver:
                    self.switches += 1
                self.receiver = best
        return next((f for f in frames if f.user == self.receiver), None)
