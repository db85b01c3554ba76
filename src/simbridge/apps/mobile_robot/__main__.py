"""`python -m simbridge.apps.mobile_robot`: the mobile-robot demo's command line."""

from __future__ import annotations

import sys

from simbridge.apps.mobile_robot.runner import main

sys.exit(main())
