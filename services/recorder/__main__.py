from services.recorder.cli import main

raise SystemExit(main())
