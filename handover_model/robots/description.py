"""What the stack needs to know about an arm: `RobotDescription` and its parts.

Frames: the scene frame is called `base` everywhere in the stack (x forward toward the
receiver, y left, z up, metres; `handover_model.scene`). It is Baxter's own base frame; any
other arm's URDF root is placed in it at `RobotDescription.base_xyz_m` / `base_rpy_rad`, so the
scene (table, object, receiver, task plane) is the same for every arm and every service keeps
working in `base`.

The tool frame follows one convention for every arm (the one Baxter's `right_gripper` has):
z is the approach axis (wrist → fingertips), y the axis the jaws close along, x = y × z, origin
between the fingertips. An arm whose URDF has no such frame gets one: `tool_parent` and
`tool_xyz_m` / `tool_rpy_rad` add a fixed frame named `TOOL_FRAME_NAME` to the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

#: Name of the tool frame added to an arm's model when its URDF has none of its own.
TOOL_FRAME_NAME = "handover_tool"


class RobotDescriptionError(Exception):
    """A robot description is missing, or one of its values is invalid (the message names it)."""


def _finite(name: str, values) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise RobotDescriptionError(f"{name} must be a list of numbers, got {values!r}") from None
    if not all(math.isfinite(v) for v in out):
        raise RobotDescriptionError(f"{name} must be finite numbers, got {values!r}")
    return out


@dataclass(frozen=True)
class GripperSpec:
    """A parallel-jaw gripper as the grip controller and the contact plant see it.

    Attributes:
        name: what it is (e.g. "Franka Hand").
        stroke_m: full opening between the jaws, m.
        force_min_n, force_max_n: the grip force it can hold, N (a gripper with a minimum
            cannot press more softly than `force_min_n` until it opens: Robotiq 2F-85, 20 N).
        force_rate_n_s: fastest change of the grip force, N/s (finger speed × pad spring).
        loop_rate_hz: rate at which the gripper takes a new command, Hz.
        source: where the figures come from (docs/robots.md cites them).
    """

    name: str
    stroke_m: float
    force_min_n: float
    force_max_n: float
    force_rate_n_s: float
    loop_rate_hz: float
    source: str = ""

    def __post_init__(self) -> None:
        for f in ("stroke_m", "force_max_n", "force_rate_n_s", "loop_rate_hz"):
            v = getattr(self, f)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise RobotDescriptionError(f"gripper.{f} must be a positive number, got {v!r}")
        if not (math.isfinite(self.force_min_n) and 0.0 <= self.force_min_n < self.force_max_n):
            raise RobotDescriptionError(f"gripper force range [{self.force_min_n}, {self.force_max_n}] N "
                                        "must have 0 <= force_min_n < force_max_n")


@dataclass(frozen=True)
class GiverStandIn:
    """The human the DJT model puts in the robot's place (thesis §2.3: Baxter as a person).

    Attributes:
        height_m, arm_span_m, weight_kg: the stand-in's body.
        shoulder_x_task_m: where its shoulder stands in the task plane (x, m; the receiver's is
            +0.5 m, the table's middle is 0).
        posture, seat_height_m: standing, or sitting on a seat this high (m): a small arm's
            stand-in sits, which lowers the transfer point into its reach.
    """

    height_m: float = 1.90
    arm_span_m: float = 2.00
    weight_kg: float = 100.0
    shoulder_x_task_m: float = -0.5
    posture: str = "standing"
    seat_height_m: float = 0.45


@dataclass(frozen=True)
class Capsule:
    """A link drawn as a capsule between two frames of the model (radius m)."""

    frame_a: str
    frame_b: str
    radius_m: float


@dataclass(frozen=True)
class RobotDescription:
    """One arm: its model, chain, tool, limits, gripper, placement and postures.

    Attributes:
        name: the model's name in profiles (`[robot] model`, `handover-up --robot`).
        title: a human name ("Franka Emika Panda").
        urdf: the URDF's path inside example-robot-data's `robots/` folder.
        joints: the arm's joints, base to tool (every other joint is locked at zero).
        tool_frame: the tool frame (see the module docstring); `TOOL_FRAME_NAME` when added.
        tool_parent, tool_xyz_m, tool_rpy_rad: where an added tool frame hangs (None: the URDF
            has the tool frame).
        base_xyz_m, base_rpy_rad: the URDF root's pose in the scene frame `base` (m, rad).
        home_rad: start and retract posture (rad, `joints` order).
        ready_rad: the posture the IK regularises toward (rad).
        velocity_rad_s, acceleration_rad_s2, jerk_rad_s3: limits per joint; an empty velocity
            tuple means the URDF's.
        velocity_scale: fraction of the velocity limits used.
        workspace_min_m, workspace_max_m: box in `base` that Cartesian goals must lie in.
        gripper: the parallel-jaw gripper.
        giver: the DJT model's stand-in for the robot.
        object_pick_base_m: where the object waits for this arm (`base`, m; on the table, or on
            a stand for a small arm).
        capsules: the links as the depth camera sees them (robot_geometry); empty: one capsule
            per link of the chain with `link_radius_m`.
        body_capsules: fixed parts (torso, pedestal) as (a, b, radius) in `base`, m.
        link_radius_m: radius of the automatic capsules, m.
    """

    name: str
    title: str
    urdf: str
    joints: tuple[str, ...]
    tool_frame: str
    home_rad: tuple[float, ...]
    gripper: GripperSpec
    tool_parent: str | None = None
    tool_xyz_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    tool_rpy_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_xyz_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_rpy_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ready_rad: tuple[float, ...] = ()
    velocity_rad_s: tuple[float, ...] = ()
    acceleration_rad_s2: tuple[float, ...] = ()
    jerk_rad_s3: tuple[float, ...] = ()
    velocity_scale: float = 1.0
    workspace_min_m: tuple[float, float, float] = (0.20, -1.30, -0.35)
    workspace_max_m: tuple[float, float, float] = (1.30, 0.30, 0.80)
    giver: GiverStandIn = GiverStandIn()
    object_pick_base_m: tuple[float, float, float] = (0.72, -0.55, -0.17)
    capsules: tuple[Capsule, ...] = ()
    body_capsules: tuple[tuple[tuple[float, float, float], tuple[float, float, float], float], ...] = ()
    link_radius_m: float = 0.05
    notes: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        n = len(self.joints)
        if n < 5 or len(set(self.joints)) != n:
            raise RobotDescriptionError(f"robot {self.name!r}: joints must name at least 5 distinct joints")
        object.__setattr__(self, "home_rad", _finite("home_rad", self.home_rad))
        object.__setattr__(self, "ready_rad", _finite("ready_rad", self.ready_rad or self.home_rad))
        for name in ("home_rad", "ready_rad"):
            if len(getattr(self, name)) != n:
                raise RobotDescriptionError(f"robot {self.name!r}: {name} needs {n} values ({', '.join(self.joints)})")
        for name in ("velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3"):
            values = _finite(name, getattr(self, name))
            if len(values) == 1:
                values = values * n
            if values and (len(values) != n or min(values) <= 0):
                raise RobotDescriptionError(f"robot {self.name!r}: {name} needs {n} positive values (or one)")
            object.__setattr__(self, name, values)
        if not self.acceleration_rad_s2 or not self.jerk_rad_s3:
            raise RobotDescriptionError(f"robot {self.name!r}: acceleration_rad_s2 and jerk_rad_s3 are required "
                                        "(URDFs carry no acceleration or jerk limits)")
        for name in ("tool_xyz_m", "tool_rpy_rad", "base_xyz_m", "base_rpy_rad", "workspace_min_m",
                     "workspace_max_m", "object_pick_base_m"):
            values = _finite(name, getattr(self, name))
            if len(values) != 3:
                raise RobotDescriptionError(f"robot {self.name!r}: {name} needs 3 numbers")
            object.__setattr__(self, name, values)
        if not 0.0 < self.velocity_scale <= 1.0:
            raise RobotDescriptionError(f"robot {self.name!r}: velocity_scale must be in (0, 1]")
        if not all(a < b for a, b in zip(self.workspace_min_m, self.workspace_max_m)):
            raise RobotDescriptionError(f"robot {self.name!r}: workspace_min_m must be below workspace_max_m")

    @property
    def dof(self) -> int:
        """Number of arm joints."""
        return len(self.joints)

    @property
    def placed(self) -> bool:
        """Whether the URDF root is moved in `base` (False: the root is `base` itself)."""
        return any(self.base_xyz_m) or any(self.base_rpy_rad)


#: Keys a profile's `[robot]` table may override, and how each is read.
_NESTED = {"gripper": GripperSpec, "giver": GiverStandIn}


def with_overrides(desc: RobotDescription, overrides: dict[str, Any], where: str = "[robot]") -> RobotDescription:
    """`desc` with the values of a profile's `[robot]` table (other than `model`) replaced.

    Raises:
        RobotDescriptionError: an unknown key, or a value the description refuses.
    """
    known = {f.name for f in fields(RobotDescription)} - {"name", "urdf", "joints", "capsules", "notes"}
    changes: dict[str, Any] = {}
    for key, value in overrides.items():
        if key not in known:
            raise RobotDescriptionError(f"{where}: unknown key {key!r}; known: {sorted(known)}")
        if key in _NESTED:
            if not isinstance(value, dict):
                raise RobotDescriptionError(f"{where}.{key} must be a table")
            nested = getattr(desc, key)
            sub_known = {f.name for f in fields(_NESTED[key])}
            bad = sorted(set(value) - sub_known)
            if bad:
                raise RobotDescriptionError(f"{where}.{key}: unknown key(s) {bad}; known: {sorted(sub_known)}")
            try:
                changes[key] = replace(nested, **value)
            except (TypeError, ValueError) as exc:
                raise RobotDescriptionError(f"{where}.{key}: {exc}") from None
        elif key == "body_capsules":
            raise RobotDescriptionError(f"{where}: body_capsules cannot be set from a profile")
        else:
            changes[key] = tuple(value) if isinstance(value, list) else value
    try:
        return replace(desc, **changes)
    except (TypeError, ValueError) as exc:
        raise RobotDescriptionError(f"{where}: {exc}") from None
