from isp.cli import main

raise SystemExit(main())
