"""``python -m hullcap``: the command line."""

import sys

from hullcap._cli import main

sys.exit(main())
