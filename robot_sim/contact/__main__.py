"""`python -m robot_sim.contact`: see `robot_sim.contact.cli`."""

import sys

from robot_sim.contact.cli import main

sys.exit(main())
