"""`python -m services.tracker` runs the tracker's CLI."""

import sys

from services.tracker.cli import main

sys.exit(main())
