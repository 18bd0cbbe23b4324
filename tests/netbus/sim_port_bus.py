"""The simulated node as a python-can bus now lives in the source (`bywire.hal.simulated.port_bus`):
`bywire verify`'s bridge campaigns run the bridge's link on it."""

from bywire.hal.simulated.port_bus import SimPortBus

__all__ = ["SimPortBus"]
