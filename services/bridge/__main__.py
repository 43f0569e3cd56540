from services.bridge.cli import main

raise SystemExit(main())
