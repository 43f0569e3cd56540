"""`python -m services.gripper`: the gripper service (see `services.gripper.cli`).

The analysis, reproduction and benchmark are offline studies:
`handover-study failsafe`, `handover-study reproduce`, `handover-study bench`.
"""

from services.gripper.cli import main

raise SystemExit(main())
