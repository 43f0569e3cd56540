"""DJT planner: where to hand the object over (thesis §2.2–2.5).

Modules, one job each:
- `anthropometrics`: body dimensions → planar two-link arm (lengths, masses, centres of mass,
  shoulder height), from named published tables.
- `djt`: the dyadic joint torque model (eqs 2.1–2.4): the model's choices (`settings`),
  analytic IK and gravity torques (`arms`), cost and cost map (`cost`), grid search and scipy
  refinement (`optimum`, `point_model`).
- `transfer_plan`: bodies and places → dyad → DJT optimum in `base` with its reach timing.
- `reach_timing`: minimum-jerk reach duration and peak speed (§2.4.2).
- `frames`: task plane ↔ scene `base` frame.
- `core`: the planner as the service uses it (inputs → TransferPlan, replan policy).
- `experiment`: the four candidate positions of the human–robot experiment (§2.5.1).
- `figures`: the cost-map figure.
"""

from services.planner.errors import PlannerError

__all__ = ["PlannerError"]
