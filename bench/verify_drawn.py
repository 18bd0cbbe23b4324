"""`bywire verify` on robot files nobody wrote: a thin wrapper of `bywire verify --draw-robots`.

Issue 30 asked for `bywire verify --budget 2000` clean on a set of drawn legal robot files; issue
41 made it the product's own feature (`bywire verify --draw-robots N`, README): every key drawn
across the range the loader itself checks, the edges most of all, a refused file repaired toward
the base file, each file verified, and each failure written to `--out` with the keys it needs.
This script keeps the bench's command line (`--robots`, a shared `--budget`) and runs it, on
every core unless `--jobs` says otherwise. Exit 1 if any file had a violation.

    python bench/verify_drawn.py --robots 20 --budget 2000 --out /tmp/drawn
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from bywire.cli.main import main


def run() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=20, help="robot files to draw (20)")
    parser.add_argument("--budget", type=int, default=2000, help="campaigns in all (2000)")
    parser.add_argument("--seed", type=int, default=0, help="drawing and verify seed (0)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="processes")
    parser.add_argument("--config", type=Path, help="base robot file (the simulator's defaults)")
    parser.add_argument("--out", type=Path, default=Path("verify-drawn"), help="output folder")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    options = parser.parse_args()
    command = [
        "verify", "--draw-robots", str(options.robots), "--budget", str(options.budget),
        "--seed", str(options.seed), "--jobs", str(options.jobs), "--out", str(options.out),
    ]  # fmt: skip
    if options.config is not None:
        command += ["--config", str(options.config)]
    if options.json:
        command.append("--json")
    return main(command)


if __name__ == "__main__":
    sys.exit(run())
