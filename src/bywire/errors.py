"""The error hierarchy: every error bywire raises on purpose derives from BywireError."""


class BywireError(Exception):
    """Root of bywire's own errors; the CLI turns these into one-line messages."""


class ConfigError(BywireError, ValueError):
    """A configuration value is missing or outside its allowed range; the message names the key."""


class FrameError(BywireError, ValueError):
    """A frame (IBUS, CAN, I2C) is malformed: wrong length, header, checksum or counter."""


class HardwareError(BywireError, OSError):
    """A device could not be opened or used; the message says what to check."""
