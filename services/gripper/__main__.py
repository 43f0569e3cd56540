"""`python -m services.gripper`: the gripper service (see `services.gripper.cli`).

The analysis, reproduction and benchmark command lines are their own modules:
`python -m services.gripper.cli_analysis`, `.reproduce`, `.benchmark`.
"""

from services.gripper.cli import main

raise SystemExit(main())
