from services.launcher.cli import main

raise SystemExit(main())
