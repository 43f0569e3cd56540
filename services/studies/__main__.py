"""`python -m services.studies`: the same as `handover-study` (see `services.studies.cli`).

Guarded: the engine's worker processes start by "spawn", which imports the parent's main
module; unguarded, each worker would run the command again."""

from services.studies.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
