"""`python -m robot_sim.contact`: see `robot_sim.contact.cli` (batches in this process;
`handover-contact` runs them on the studies' engine)."""

import sys

from robot_sim.contact.cli import main

if __name__ == "__main__":
    sys.exit(main())
