"""A python-can adapter that a test can pull out and plug back in: buses opened through the
real `open_bus` (python-can's virtual interface), whose every call fails while unplugged."""

from __future__ import annotations

import can

from bywire.errors import HardwareError
from bywire.hal.linux.can_open import BusSettings, open_bus


class Unpluggable:
    """Opens virtual buses through `open_bus`; while unplugged, every bus call fails."""

    def __init__(self) -> None:
        self.plugged = True
        self.opened = 0

    def __call__(self, settings: BusSettings) -> can.BusABC:
        if not self.plugged:
            raise HardwareError("CAN: no such device")
        self.opened += 1
        bus = open_bus(settings)
        original_recv, original_send = bus.recv, bus.send

        def recv(timeout: float | None = None) -> can.Message | None:
            self._check()
            return original_recv(timeout)

        def send(msg: can.Message, timeout: float | None = None) -> None:
            self._check()
            original_send(msg, timeout)

        # mypy refuses any assignment to a method; this one wraps python-can's own bus methods
        bus.recv, bus.send = recv, send  # type: ignore[method-assign]
        return bus

    def _check(self) -> None:
        if not self.plugged:
            raise can.CanOperationError("No such device", 19)
