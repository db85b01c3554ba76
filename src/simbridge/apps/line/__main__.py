"""`python -m simbridge.apps.line`: the line demo."""

import sys

from simbridge.apps.line.runner import main

sys.exit(main())
