"""bywire: the low-level controller of a drive-by-wire delivery robot."""

__version__ = "0.1.0"
