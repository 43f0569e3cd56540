"""Offline studies of the stack: benchmarks, thesis reproductions, figures and evaluations.

None of these runs on the bus. They import the services' cores and the simulator; no service
imports them. One command line, `handover-study` (`services.studies.cli`), runs them all.

Packages:
- `gripper`: the release controllers' Monte-Carlo benchmark and its drop attribution, the
  fail-safe law's analysis, the reproduction of thesis Figures 20-23;
- `planner`: the candidate positions of the thesis's human-robot experiment, the DJT figures;
- `motion`: the motion figures;
- `tracker`: simulated tracker episodes and the tracker's evaluation against the truth.
"""
