"""`python -m services.planner` runs the planner CLI."""

import sys

from services.planner.cli import main

sys.exit(main())
