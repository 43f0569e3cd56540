"""The arms the stack can drive, and which one this process drives.

A deploy profile names its arm in a `[robot]` table (`model = "baxter" | "panda" | "ur5" |
"so_arm101"`, plus any value of `RobotDescription` to override, e.g. `base_xyz_m` or
`[robot.gripper] force_max_n`); `handover-up --robot NAME` replaces the model for one run
(through `HANDOVER_ROBOT`, which every service it starts inherits: the profile's overrides
then apply only if they were written for that model). Every service reads its arm from here:
`active()` after `use_profile(...)`. docs/robots.md says how to describe a new arm.

Modules:
- `description`: `RobotDescription` and its parts (gripper, giver stand-in, capsules);
- `urdf`: the URDF from example-robot-data, placed in the scene and given a tool frame;
- `model`: pinocchio forward kinematics and joint limits;
- `baxter`, `others`: the built-in descriptions.
"""

from __future__ import annotations

import os
from typing import Any

from handover_model.robots.baxter import BAXTER
from handover_model.robots.description import (
    Capsule,
    GiverStandIn,
    GripperSpec,
    RobotDescription,
    RobotDescriptionError,
    with_overrides,
)
from handover_model.robots.model import ArmModel, JointLimits, arm_model_of
from handover_model.robots.others import PANDA, SO_ARM101, UR5
from handover_model.robots.urdf import model_urdf_text, placed_urdf_file, share_dir, urdf_path

__all__ = ["ArmModel", "BAXTER", "BUILTIN", "Capsule", "DEFAULT_ROBOT", "GiverStandIn", "GripperSpec", "JointLimits",
           "ROBOT_ENV", "RobotDescription", "RobotDescriptionError", "active", "arm_model", "describe",
           "from_profile", "model_urdf_text", "placed_urdf_file", "share_dir", "urdf_path", "use"]

#: Environment variable that replaces the profile's `[robot] model` (set by `handover-up --robot`).
ROBOT_ENV = "HANDOVER_ROBOT"
DEFAULT_ROBOT = "baxter"
BUILTIN: dict[str, RobotDescription] = {d.name: d for d in (BAXTER, PANDA, UR5, SO_ARM101)}

_active: RobotDescription | None = None


def describe(name: str, overrides: dict[str, Any] | None = None, where: str = "[robot]") -> RobotDescription:
    """The built-in description `name` with `overrides` applied.

    Raises:
        RobotDescriptionError: an unknown model or a bad override.
    """
    if name not in BUILTIN:
        raise RobotDescriptionError(f"{where}: unknown robot model {name!r}; known: {sorted(BUILTIN)}")
    return with_overrides(BUILTIN[name], overrides or {}, where) if overrides else BUILTIN[name]


def from_profile(doc: dict[str, Any], where: str = "profile",
                 environ: dict[str, str] | None = None) -> RobotDescription:
    """The arm a profile document (its parsed TOML) describes, `HANDOVER_ROBOT` applied.

    Raises:
        RobotDescriptionError: `[robot]` is not a table, names an unknown model or a bad value.
    """
    table = doc.get("robot", {})
    if not isinstance(table, dict):
        raise RobotDescriptionError(f"{where}: [robot] must be a table")
    table = dict(table)
    model = table.pop("model", DEFAULT_ROBOT)
    if not isinstance(model, str):
        raise RobotDescriptionError(f"{where}: [robot] model must be a name, one of {sorted(BUILTIN)}")
    forced = (os.environ if environ is None else environ).get(ROBOT_ENV, "").strip()
    if forced and forced != model:
        return describe(forced, None, f"{ROBOT_ENV}={forced}")
    return describe(model, table, f"{where}: [robot]")


def use(desc: RobotDescription) -> RobotDescription:
    """Make `desc` this process's arm (what `active()` returns); returns it."""
    global _active
    _active = desc
    return desc


def active() -> RobotDescription:
    """This process's arm: the one `use` set, else `HANDOVER_ROBOT`'s built-in, else Baxter."""
    if _active is not None:
        return _active
    forced = os.environ.get(ROBOT_ENV, "").strip()
    return describe(forced or DEFAULT_ROBOT, None, f"{ROBOT_ENV}={forced}")


def arm_model(desc: RobotDescription | None = None) -> ArmModel:
    """The cached pinocchio model of `desc` (default: the active arm)."""
    return arm_model_of(desc or active())
