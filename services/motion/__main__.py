"""`python -m services.motion`: the `handover-motion` command."""

from services.motion.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
