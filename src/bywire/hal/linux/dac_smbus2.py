"""The DAC6574 through smbus2: each 3-byte frame of `protocol.dac6574` as one raw I2C write.

`i2c_rdwr` sends the address byte and the frame as one transfer, exactly the chip's write
sequence (no SMBus register byte in front). A missing acknowledge comes back from the kernel as
an OSError (EREMOTEIO, EIO) and leaves here as HardwareError, which the runtime counts.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from typing import Protocol

from smbus2 import SMBus, i2c_msg

from bywire.errors import FrameError, HardwareError
from bywire.hal.linux.device_errors import device_error, reason
from bywire.protocol import dac6574

MISSING_HINT = "enable I2C (Raspberry Pi: dtparam=i2c_arm=on) or fix drive.dac.i2c_bus"


class RawI2cBus(Protocol):
    """The part of `smbus2.SMBus` used here."""

    def i2c_rdwr(self, *i2c_msgs: i2c_msg) -> None: ...

    def close(self) -> None: ...


BusOpener = Callable[[str], RawI2cBus]


class Smbus2Dac:
    """An `I2cDevice` for the DAC6574 at `address` on the I2C bus device `bus_path`.

    Opening writes 0 V to every channel (safe start, and proof that the chip answers);
    `close()` does it again before releasing the bus.
    """

    def __init__(self, bus_path: str, address: int, *, open_bus: BusOpener | None = None) -> None:
        self.bus_path = bus_path
        self.address = dac6574.check_address(address)
        self.writes = self.failed_writes = 0
        try:
            self._bus: RawI2cBus | None = (open_bus or SMBus)(bus_path)
        except OSError as error:
            raise device_error(
                "DAC6574", bus_path, error, group="i2c", missing=MISSING_HINT
            ) from error
        try:
            self._zero_all()
        except HardwareError as error:
            self._release()
            raise HardwareError(
                f"{error}: check the wiring, power and pins A1 A0 (drive.dac.address)"
            ) from error

    def write(self, data: bytes) -> None:
        bus = self._bus
        if bus is None:
            raise HardwareError(f"DAC6574 on {self.bus_path}: closed")
        try:
            dac6574.decode_frame(data)  # what the chip would not acknowledge is never sent
        except FrameError as error:
            self.failed_writes += 1
            raise HardwareError(f"DAC6574: frame not sent: {error}") from error
        try:
            bus.i2c_rdwr(i2c_msg.write(self.address, data))
        except OSError as error:
            self.failed_writes += 1
            raise HardwareError(
                f"DAC6574 at 0x{self.address:02X} on {self.bus_path}: no acknowledge"
                f" ({reason(error)})"
            ) from error
        self.writes += 1

    def close(self) -> None:
        """0 V on every channel (best effort), then release the bus; safe to call again."""
        if self._bus is None:
            return
        # A chip that is gone cannot be zeroed; the enable line already holds the motors off.
        with contextlib.suppress(HardwareError):
            self._zero_all()
        self._release()

    def _zero_all(self) -> None:
        for channel in dac6574.CHANNELS:
            self.write(dac6574.encode_write(channel, 0))

    def _release(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            bus.close()
