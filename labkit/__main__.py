"""``python -m labkit`` runs the command line (see :mod:`labkit.cli`)."""

import sys

from labkit.cli import main

sys.exit(main())
