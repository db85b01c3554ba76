"""`python -m simbridge.apps.pick_and_place`: the pick-and-place demo's command line."""

from __future__ import annotations

import sys

from simbridge.apps.pick_and_place.runner import main

sys.exit(main())
