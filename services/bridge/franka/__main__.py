"""``python -m services.bridge.franka``: see `services.bridge.franka.cli`."""

from services.bridge.franka.cli import main

raise SystemExit(main())
