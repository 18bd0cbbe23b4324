"""Run `bywire bench` from a checkout: ``python bench/run.py [--quick] [--json] [--duration S]``.

The measuring code lives in ``src/bywire/bench`` so that the installed ``bywire bench`` has it;
this script only forwards its arguments (bywire must be installed, e.g. ``pip install -e .``).
"""

from __future__ import annotations

import sys

from bywire.cli.main import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
