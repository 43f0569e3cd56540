"""Typed configuration of the recorder (`[services.recorder.config]` in a deploy profile).

Example (deploy/sim.toml)::

    [services.recorder.config]
    robot_model = "primitives"   # the arm as its URDF's boxes and cylinders (+ torso hull), ~30 kB
    depth_every = 0              # depth images are not even received (0), or one in N
    flush_period_s = 1.0         # written and flushed this often: the most a SIGKILL loses
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec
from msgspec import Meta

from bus_schema import TOPICS, Topic, topics
from services.recorder.errors import RecorderError

#: How the arm is drawn: ``primitives`` (the URDF's collision boxes and cylinders, its small
#: visual primitives and a convex hull of the torso: ~30 kB per recording), ``meshes`` (every
#: Collada mesh of the URDF, as `rr.log_file_from_path` loads it: ~16 MB per recording) or
#: ``none`` (no robot in the 3-D view; the joint series are still recorded).
RobotModelMode = Literal["primitives", "meshes", "none"]


class RecorderConfig(msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True):
    """Recorder settings.

    Attributes:
        output_dir: folder of the recordings (``handover-<run id>.rrd``).
        flush_period_s: buffered messages are written and the file flushed this often, s;
            a SIGKILL loses at most this much of the received messages. Longer periods make
            larger chunks: a smaller file and less CPU (see docs/recorder.md).
        depth_every: 0 (default): ``perception/depth`` is not subscribed, so its 150 kB images
            (4.6 MB/s at 30 Hz) never reach the process; N ≥ 1: subscribe, record every
            frame's numbers and the image of one frame in N (1: every image, 30 Hz).
        robot_model: how the arm is drawn (`RobotModelMode`).
        robot_pose_every: joint transforms of the arm's model (the 3-D robot's pose) for one
            joint state in N (the joint positions themselves are recorded for every message).
    """

    output_dir: str = "recordings"
    flush_period_s: Annotated[float, Meta(ge=0.05, le=10.0)] = 1.0
    depth_every: Annotated[int, Meta(ge=0, le=100)] = 0
    robot_model: RobotModelMode = "primitives"
    robot_pose_every: Annotated[int, Meta(ge=1, le=100)] = 4


def parse_config(table: dict[str, Any]) -> RecorderConfig:
    """Validate `[services.recorder.config]`.

    Raises:
        RecorderError: naming the bad key.
    """
    if "urdf" in table:
        raise RecorderError('[services.recorder.config].urdf was replaced by robot_model = "primitives" | '
                            '"meshes" | "none"')
    try:
        return msgspec.convert(table, RecorderConfig)
    except msgspec.ValidationError as exc:
        raise RecorderError(f"invalid [services.recorder.config]: {exc}") from None


def recorded_topics(depth_every: int) -> tuple[Topic, ...]:
    """The keys the recorder subscribes to: every key of the topic table, depth only when
    `depth_every` ≥ 1, never the simulation clock's steps (each message's time is its stamp:
    the recording's timeline is the simulated time already)."""
    return tuple(t for t in TOPICS if (t is not topics.DEPTH or depth_every > 0)
                 and t not in (topics.CLOCK, topics.CLOCK_READY))
