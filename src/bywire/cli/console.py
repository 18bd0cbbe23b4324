"""The console a command prints its tables to: the terminal's width there, wide when piped.

rich takes 80 columns for anything that is not a terminal, so `bywire monitor --once | less -S`
or `bywire bench > results.txt` had their rows cut with "…" or wrapped onto a second line, which
no reader of a file or grep wants. Piped, a table is printed at its own width (a COLUMNS set in
the environment still wins, as rich reads it).
"""

from __future__ import annotations

import os
import sys
from typing import Any

from rich.console import Console

PIPED_WIDTH = 400  # wider than any table bywire prints: rows keep their natural width


class _StdoutConsole(Console):
    """rich exits 1 when the reader goes away; `bywire sim | head` is no error (main says so)."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        raise BrokenPipeError


def stdout_console(**options: Any) -> Console:
    """A rich Console on stdout, as wide as a table needs when stdout is not a terminal."""
    if not sys.stdout.isatty() and "COLUMNS" not in os.environ:
        options.setdefault("width", PIPED_WIDTH)
    return _StdoutConsole(**options)
