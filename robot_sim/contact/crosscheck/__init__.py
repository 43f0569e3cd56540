"""An independent plant for the contact simulator: the same scenarios in MuJoCo, compared
point by point (issue 22, item 2; docs/contact.md, "Independent cross-check (MuJoCo)").

- `mjcf`: the MuJoCo model (two force-driven pads pinch a box; elliptic friction cones,
  soft contacts; parameters in `MujocoParams`), built in code, no assets;
- `scenario`: what both plants are given (object, grip schedule, a prescribed hand force
  or a receiver behaviour);
- `runs`: one scenario on our plant (stepped directly) or on MuJoCo, the same time series;
- `measure`: slip onset, leaving the pads, slide distance, caught, dropped, overshoot;
- `compare`: rows (ours, MuJoCo, difference, tolerance, agree) and what did not come out as
  stated; `catalogue`: the cases; `report`, `plots`: tables and figures.

`handover-study crosscheck` runs it. Gripper frame throughout (x toward the receiver, y DOWN),
SI units. Importing a module of this package imports `mujoco`.
"""
