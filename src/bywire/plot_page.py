"""The page every plot bywire draws is drawn on (`bywire sim --plot`, `bywire plot`).

Kept apart from the plotters so that reading it never loads matplotlib: `bywire sim` without
`--plot` must not pay for it.
"""

from __future__ import annotations

SIZE_IN = (11.0, 12.0)
DPI = 100
