"""``python -m gps_error_ros.cli``: the ``gps_error`` command."""

from gps_error_ros.cli import main

raise SystemExit(main())
