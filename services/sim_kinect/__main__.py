from services.sim_kinect.cli import main

raise SystemExit(main())
