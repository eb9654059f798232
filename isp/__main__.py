"""``python -m isp``: the ``isp`` command line (:func:`isp.cli.main`)."""

from isp.cli import main

raise SystemExit(main())
