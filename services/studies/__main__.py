"""`python -m services.studies`: the same as `handover-study` (see `services.studies.cli`)."""

from services.studies.cli import main

raise SystemExit(main())
