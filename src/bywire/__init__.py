"""bywire: the low-level controller of a drive-by-wire delivery robot."""

__version__ = "0.1.0"

from bywire.build import check as _check_build

_check_build()  # a compiled build whose sources changed since refuses to run (issue 43)
