"""``python -m zonotope``: the ``zonotope`` command line (:func:`zonotope.cli.main`)."""

from zonotope.cli import main

raise SystemExit(main())
