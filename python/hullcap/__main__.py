"""``python -m hullcap``: the command line."""

import sys

from hullcap.cli import main

sys.exit(main())
