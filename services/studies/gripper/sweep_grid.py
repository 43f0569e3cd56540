"""The grid of `handover-study sweep`: one or two parameters of a release controller, each
given as a range or an explicit list of values, and the grid points (every combination).

    NAME=LO:HI:N          N values from LO to HI (both included), log-spaced where the
                          tuning's search box (`tuning.SPACES`) says so, else linear
    NAME=LO:HI:N:log      log-spaced (LO, HI > 0)
    NAME=LO:HI:N:lin      linearly spaced
    NAME=V1,V2,...        exactly these values (a single value is allowed)

NAME is a parameter of the controller (the fields of its parameters' dataclass, e.g.
`SlipGuardParams`); every grid point is checked by building the controller with it before any
episode runs, so a value the controller refuses (a cap below the minimum hold, …) is bad input.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np

from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.tuning import SPACES

__all__ = ["MAX_AXES", "MAX_POINTS", "SweepAxis", "controller_parameters", "grid_points", "parse_axis"]

#: At most this many swept parameters (a line or a heat map).
MAX_AXES = 2
#: At most this many values on one axis (a typo such as 5:50:1000 is refused, not run).
MAX_POINTS = 200


@dataclass(frozen=True)
class SweepAxis:
    """One swept parameter: its name, its values (in the order given) and whether they are
    log-spaced (the plot's axis scale)."""

    name: str
    values: tuple[float, ...]
    log: bool = False


def controller_parameters(controller: str) -> list[str]:
    """The numeric parameters of a registered controller (its parameters' dataclass fields)."""
    params = getattr(make_controller(controller), "params", None)
    if params is None or not dataclasses.is_dataclass(params):
        raise GripperError(f"controller {controller} has no parameters to sweep")
    return [f.name for f in dataclasses.fields(params)
            if isinstance(getattr(params, f.name), (int, float)) and not isinstance(getattr(params, f.name), bool)]


def _number(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise GripperError(f"--param {spec!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise GripperError(f"--param {spec!r}: {text!r} is not a finite number")
    return value


def _default_log(controller: str, name: str) -> bool:
    """Log spacing where the tuning's search box for the controller (or its base) says so."""
    for space in SPACES.values():
        if name in space.bounds and (controller == space.controller or controller.startswith(space.controller)):
            return space.bounds[name][2]
    return False


def parse_axis(spec: str, controller: str) -> SweepAxis:
    """`NAME=LO:HI:N[:log|lin]` or `NAME=V1,V2,…` → a `SweepAxis`; `GripperError` (one line,
    naming what to fix) for an unknown parameter, a malformed or empty range, N < 1, a log range
    through zero, repeated values or more than `MAX_POINTS` values."""
    name, sep, rest = spec.partition("=")
    name, rest = name.strip(), rest.strip()
    if not sep or not name or not rest:
        raise GripperError(f"--param {spec!r}: expected NAME=LO:HI:N or NAME=V1,V2,... (e.g. hold_per_weight=2:15:8)")
    known = controller_parameters(controller)
    if name not in known:
        raise GripperError(f"--param {spec!r}: {controller} has no parameter {name!r}; it has: {', '.join(known)}")
    if ":" in rest:
        values, log = _range(spec, controller, name, rest.split(":"))
    else:
        values = tuple(_number(v.strip(), spec) for v in rest.split(",") if v.strip())
        log = _default_log(controller, name) and all(v > 0 for v in values)
        if not values:
            raise GripperError(f"--param {spec!r}: no value given")
    if len(set(values)) != len(values):
        raise GripperError(f"--param {spec!r}: a value is repeated")
    if len(values) > MAX_POINTS:
        raise GripperError(f"--param {spec!r}: {len(values)} values, at most {MAX_POINTS} per parameter")
    return SweepAxis(name, values, log)


def _range(spec: str, controller: str, name: str, parts: list[str]) -> tuple[tuple[float, ...], bool]:
    if len(parts) not in (3, 4):
        raise GripperError(f"--param {spec!r}: a range is LO:HI:N or LO:HI:N:log|lin")
    lo, hi = _number(parts[0], spec), _number(parts[1], spec)
    try:
        n = int(parts[2])
    except ValueError:
        raise GripperError(f"--param {spec!r}: N {parts[2]!r} is not a whole number") from None
    if n < 1:
        raise GripperError(f"--param {spec!r}: N must be >= 1, got {n}")
    if n > MAX_POINTS:
        raise GripperError(f"--param {spec!r}: {n} values, at most {MAX_POINTS} per parameter")
    if n > 1 and not lo < hi:
        raise GripperError(f"--param {spec!r}: LO must be below HI, got {lo:g} and {hi:g}")
    scale = parts[3].strip().lower() if len(parts) == 4 else ("log" if _default_log(controller, name) else "lin")
    if scale not in ("log", "lin"):
        raise GripperError(f"--param {spec!r}: spacing {parts[3]!r} is not log or lin")
    if scale == "log" and lo <= 0:
        raise GripperError(f"--param {spec!r}: a log range needs LO > 0, got {lo:g} (use :lin)")
    if n == 1:
        return (lo,), scale == "log"
    grid = np.geomspace(lo, hi, n) if scale == "log" else np.linspace(lo, hi, n)
    return tuple(float(v) for v in grid), scale == "log"


def grid_points(controller: str, axes: list[SweepAxis]) -> list[dict[str, float]]:
    """Every combination of the axes' values (the first axis slowest), each checked by building
    the controller with it; `GripperError` naming the first point the controller refuses."""
    if not 1 <= len(axes) <= MAX_AXES:
        raise GripperError(f"sweep one or two parameters (--param given {len(axes)} times)")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise GripperError(f"--param names {names[0]!r} twice")
    points = [dict(zip(names, combo)) for combo in itertools.product(*(a.values for a in axes))]
    for p in points:
        try:
            make_controller(controller, **p)
        except GripperError as exc:
            shown = ", ".join(f"{k}={v:g}" for k, v in p.items())
            raise GripperError(f"grid point {shown}: {exc}") from None
    return points
