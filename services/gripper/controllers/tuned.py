"""Tuned parameter presets (`SG-tuned`, `HI-tuned`, ...): a registered controller with the
parameters `handover-study tune` found, read from `tuned_presets.json` next to this module.

The file maps a preset's name to its base controller, its parameters and how they were found:

    {"SG-tuned": {"base": "SG", "params": {"hold_per_weight": 6.1, ...},
                  "provenance": {"seed": 1000, "episodes": 960, "objective": ..., ...}}}
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from services.gripper.errors import GripperError

__all__ = ["PRESETS_PATH", "load_presets", "save_preset"]

#: Where `handover-study tune --write-preset` writes and the registry reads the presets.
PRESETS_PATH = Path(__file__).with_name("tuned_presets.json")


def load_presets(path: Path = PRESETS_PATH) -> dict[str, dict]:
    """Every preset of `path` (an empty dict if the file does not exist). Raises GripperError
    for a file that cannot be read or a preset without a base controller or parameters."""
    path = Path(path)
    if not path.exists():
        return {}
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise GripperError(f"cannot read the tuned presets {path}: {exc}; rerun `handover-study tune`") from exc
    if not isinstance(doc, dict):
        raise GripperError(f"{path}: expected an object of presets, got {type(doc).__name__}")
    for name, entry in doc.items():
        if not (isinstance(entry, dict) and isinstance(entry.get("base"), str)
                and isinstance(entry.get("params"), dict)):
            raise GripperError(f"{path}: preset {name!r} needs a 'base' controller name and a 'params' object")
        for key, value in entry["params"].items():
            if not (isinstance(value, (int, float)) and math.isfinite(value)):
                raise GripperError(f"{path}: preset {name!r}: parameter {key} = {value!r} is not a finite number")
    return doc


def save_preset(name: str, base: str, params: dict[str, float], provenance: dict,
                path: Path = PRESETS_PATH) -> Path:
    """Add or replace preset `name` in `path` (the other presets are kept); written atomically."""
    path = Path(path)
    doc = load_presets(path)
    doc[name] = {"base": base, "params": {k: float(v) for k, v in params.items()}, "provenance": provenance}
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
    tmp.replace(path)
    return path
