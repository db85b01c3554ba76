"""`python -m simbridge.cli`."""

import sys

from simbridge.cli import main

sys.exit(main())
