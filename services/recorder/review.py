"""Review entities that need memory across messages (pure, no I/O).

- the tool path: `sim/truth.tool_position_m` as a growing line strip ``world/tool_path``
  (a point is added once the tool has moved `min_spacing_m` from the last one; the strip
  restarts when the supervisor starts a new episode);
- the motion goal: an arrow ``world/motion/goal_arrow`` from the tool to each new Cartesian
  goal;
- the release: a marker ``world/release`` where the tool was when the gripper released, and
  the grip force at release as a point series ``signals/release_grip_force_n``;
- the event log ``events``: an event is logged when it changed (`EventLog`).

`ReviewState` must see its messages in time order across keys (the writer merges them by stamp).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import rerun as rr

from bus_schema import messages as m
from services.recorder.core import Vec3, event_is_warning, event_key, event_text


@dataclass
class ToolPath:
    """Growing polyline of the tool in the `base` frame (m)."""

    min_spacing_m: float = 0.005
    max_points: int = 5_000
    points: list[Vec3] = field(default_factory=list)
    changed: bool = False

    def add(self, position_m: Vec3) -> None:
        if self.points and math.dist(self.points[-1], position_m) < self.min_spacing_m:
            return
        self.points.append(tuple(position_m))
        if len(self.points) > self.max_points:
            del self.points[: len(self.points) - self.max_points]
        self.changed = True

    def restart(self) -> None:
        self.points.clear()
        self.changed = True


@dataclass
class ReviewState:
    """Remembers what the review entities need (last tool position, episode, path)."""

    tool_path: ToolPath = field(default_factory=ToolPath)
    tool_position_m: Vec3 | None = None
    episode_id: int | None = None

    def on_message(self, msg: m.Message) -> list[tuple[str, Any]]:
        """Archetypes to log now, at this message's time (the path is sent by `path_update`)."""
        out: list[tuple[str, Any]] = []
        if isinstance(msg, m.SimTruth):
            self.tool_position_m = msg.tool_position_m
            self.tool_path.add(msg.tool_position_m)
        elif isinstance(msg, m.SupervisorState):
            if self.episode_id is not None and msg.episode_id != self.episode_id:
                self.tool_path.restart()
            self.episode_id = msg.episode_id
        elif isinstance(msg, m.MotionGoal):
            if msg.position_base_m is not None and self.tool_position_m is not None:
                vector = tuple(g - t for g, t in zip(msg.position_base_m, self.tool_position_m, strict=True))
                out.append(("world/motion/goal_arrow", rr.Arrows3D(
                    origins=[self.tool_position_m], vectors=[vector], labels=[msg.goal_id],
                    colors=[(170, 60, 220)], radii=0.006)))
        elif isinstance(msg, m.ReleaseEvent):
            out.append(("signals/release_grip_force_n", rr.Scalars(msg.grip_force_n)))
            if self.tool_position_m is not None:
                out.append(("world/release", rr.Points3D([self.tool_position_m], radii=0.045,
                                                         colors=[(255, 40, 40)],
                                                         labels=[f"release ({msg.controller})"])))
        return out

    def path_update(self) -> tuple[str, Any] | None:
        """The tool path strip when it changed since the last call, else None."""
        if not self.tool_path.changed:
            return None
        self.tool_path.changed = False
        strips = [self.tool_path.points] if len(self.tool_path.points) >= 2 else []
        return ("world/tool_path", rr.LineStrips3D(strips, radii=0.007, colors=[(60, 120, 255)]))


@dataclass
class EventLog:
    """Lines of the event log (``events``): an event message is logged when its `event_key`
    changed since the last message of its key (stops and releases: every one)."""

    last_key: dict[str, tuple] = field(default_factory=dict)

    def rows(self, suffix: str, msgs: list[m.Message]) -> tuple[list[int], list[str], list[str]]:
        """(message indices, texts, levels) of the lines a batch of `suffix`'s messages adds."""
        rows: list[int] = []
        texts: list[str] = []
        levels: list[str] = []
        last = self.last_key.get(suffix)
        for i, msg in enumerate(msgs):
            key = event_key(msg)
            if key is None or key == last:
                continue
            last = key
            text = event_text(msg)
            if text:
                rows.append(i)
                texts.append(text)
                levels.append(rr.TextLogLevel.WARN if event_is_warning(msg) else rr.TextLogLevel.INFO)
        if last is not None:
            self.last_key[suffix] = last
        return rows, texts, levels
