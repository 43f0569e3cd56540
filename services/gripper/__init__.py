"""Fail-safe gripper: release controllers of the object-transfer loop (thesis §3.4–3.6).

Modules:
- `controllers`: the fail-safe law (eq 3.19) and its presets, the human-inspired law of
  Chan et al. (eq 3.22), the §3.1 baselines and our slip-guarded controller (SG), all
  behind one vectorised interface.
- `analysis`: start/stable force thresholds, rest condition, tolerated acceleration, φ_max.
- `spring`: the thesis's spring between grip force and gripper position (eq 3.21).
- `reproduce`: Figures 20–23 of the thesis from `robot_sim.thesis_model`.
- `config`, `core`, `node`, `cli`: the gripper service on the bus (`python -m services.gripper`).
- `episodes`, `benchmark`: the Monte-Carlo controller benchmark on the realistic contact plant
  (`python -m services.gripper.benchmark`, console script `handover-bench`).
"""

from services.gripper.errors import GripperError

__all__ = ["GripperError"]
