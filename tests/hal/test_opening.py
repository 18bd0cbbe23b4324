"""The chooser's Linux openers: one per device, keyed by a typed name, in the safe order."""

from __future__ import annotations

from bywire.config import RobotConfig
from bywire.hal.linux.clock import LinuxClock
from bywire.hal.opening import Device, LinuxPaths, linux_openers


def test_every_device_has_one_opener_and_the_outputs_open_first() -> None:
    """GPIO lines first (requested low: motors off, e-brake on), then the DAC and the PWMs,
    the inputs last; each device once, by the name `bywire run --check` prints."""
    openers = linux_openers(RobotConfig(backend="linux"), LinuxPaths(), LinuxClock())
    order = [device for device, _ in openers.in_order()]
    assert order == list(Device)
    assert order[0] is Device.GPIO
    assert order[-2:] == [Device.RC_UART, Device.CAN]
    assert len(set(order)) == len(order)
