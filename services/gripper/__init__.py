"""Fail-safe gripper: release controllers of the object-transfer loop (thesis §3.4–3.6).

Modules:
- `controllers`: the fail-safe law (eq 3.19) and its presets, the human-inspired law of
  Chan et al. (eq 3.22), the §3.1 baselines and our slip-guarded controller (SG), all
  behind one vectorised interface.
- `spring`: the thesis's spring between grip force and gripper position (eq 3.21).
- `config`, `core`, `node`, `cli`: the gripper service on the bus (`python -m services.gripper`).

The analysis of the fail-safe law, the reproduction of the thesis's figures and the Monte-Carlo
benchmark are offline studies in `services.studies.gripper` (`handover-study`).
"""

from services.gripper.errors import GripperError

__all__ = ["GripperError"]
