"""`python -m bywire`: the same entry point as the `bywire` script (child processes use it)."""

import sys

from bywire.cli.main import main

sys.exit(main())
