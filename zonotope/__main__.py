from zonotope.cli import main

raise SystemExit(main())
