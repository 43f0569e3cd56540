"""``python -m services.bridge.baxter``: see `services.bridge.baxter.cli`."""

from services.bridge.baxter.cli import main

raise SystemExit(main())
