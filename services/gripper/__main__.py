"""`python -m services.gripper`: the analysis and reproduction command line.

The gripper service itself (bus node) is not part of this package yet.
"""

import sys

from services.gripper.analysis_cli import main

sys.exit(main())
