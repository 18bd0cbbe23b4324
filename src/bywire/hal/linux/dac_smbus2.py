"""The DAC6574 through smbus2: each 3-byte frame of `protocol.dac6574` as one I2C write.

On an adapter that carries plain I2C, `i2c_rdwr` sends the address byte and the frame as one
transfer, exactly the chip's write sequence. An SMBus-only adapter (Intel i801-class
controllers, the kernel's i2c-stub) refuses plain I2C (EOPNOTSUPP); there the frame goes as an
SMBus "I2C block" write with the control byte as its command byte, which puts the same bytes on
the wire: start, address + W, control, MSB, LSB, stop. The adapter's functions (I2C_FUNCS) pick
the way at open, and an EOPNOTSUPP later is named as what it is, not as a missing acknowledge.

Opening claims the address the way i2c-dev's tools do (I2C_SLAVE, not I2C_SLAVE_FORCE): the
kernel says EBUSY when a driver of its own is bound to it (ti-dac5571), and writing behind that
driver's back is refused. A missing acknowledge comes back as an OSError (ENXIO, EREMOTEIO, EIO)
and leaves here as HardwareError, which the runtime counts.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
from collections.abc import Callable, Sequence
from typing import Protocol

from smbus2 import I2cFunc, SMBus, i2c_msg

from bywire.errors import FrameError, HardwareError
from bywire.hal.linux.device_errors import device_error, reason
from bywire.protocol import dac6574

log = logging.getLogger(__name__)
MISSING_HINT = "enable I2C (Raspberry Pi: dtparam=i2c_arm=on) or fix drive.dac.i2c_bus"
I2C_SLAVE = 0x0703  # linux/i2c-dev.h: use this address, unless a kernel driver owns it
NOT_SUPPORTED = frozenset({errno.EOPNOTSUPP, errno.ENOTSUP})


class RawI2cBus(Protocol):
    """The part of `smbus2.SMBus` used here, and claiming an address."""

    funcs: I2cFunc

    def claim(self, address: int) -> None: ...

    def i2c_rdwr(self, *i2c_msgs: i2c_msg) -> None: ...

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None: ...

    def close(self) -> None: ...


class KernelI2cBus(SMBus):
    """smbus2's bus on /dev/i2c-N, which also claims an address as i2c-dev's tools do."""

    def claim(self, address: int) -> None:
        if self.fd is None:
            raise OSError(errno.EBADF, "the bus is closed")
        fcntl.ioctl(self.fd, I2C_SLAVE, address)


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
        self.smbus_only = False
        """True on an adapter without plain I2C: frames go as SMBus I2C-block writes."""
        try:
            self._bus: RawI2cBus | None = (open_bus or KernelI2cBus)(bus_path)
        except OSError as error:
            raise device_error(
                "DAC6574", bus_path, error, group="i2c", missing=MISSING_HINT
            ) from error
        try:
            self._claim(self._bus)
            self._zero_all()
        except HardwareError as error:
            self._release()
            if "acknowledge" not in str(error):
                raise
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
            if self.smbus_only:
                bus.write_i2c_block_data(self.address, data[0], list(data[1:]))
            else:
                bus.i2c_rdwr(i2c_msg.write(self.address, data))
        except OSError as error:
            self.failed_writes += 1
            raise self._write_error(error) from error
        self.writes += 1

    def close(self) -> None:
        """0 V on every channel (best effort), then release the bus; safe to call again."""
        if self._bus is None:
            return
        # A chip that is gone cannot be zeroed; the enable line already holds the motors off.
        with contextlib.suppress(HardwareError):
            self._zero_all()
        self._release()

    def _where(self) -> str:
        return f"DAC6574 at 0x{self.address:02X} on {self.bus_path}"

    def _claim(self, bus: RawI2cBus) -> None:
        """Refuse an address a kernel driver owns; choose plain I2C or SMBus I2C-block."""
        try:
            bus.claim(self.address)
        except OSError as error:
            if error.errno != errno.EBUSY:
                raise HardwareError(f"{self._where()}: {reason(error)}") from error
            client = f"{self.bus_path.rpartition('i2c-')[2]}-{self.address:04x}"
            raise HardwareError(
                f"{self._where()}: a kernel driver owns this address (EBUSY): unbind it"
                f" (echo {client} | sudo tee /sys/bus/i2c/devices/{client}/driver/unbind)"
                " or use the kernel's IIO driver, which bywire takes by itself when it is"
                " ti-dac5571 (compatible ti,dac6574)"
            ) from error
        if not bus.funcs & I2cFunc.I2C:
            if not bus.funcs & I2cFunc.SMBUS_WRITE_I2C_BLOCK:
                raise HardwareError(
                    f"{self._where()}: this adapter can do neither plain I2C nor SMBus"
                    " I2C-block writes: wire the DAC to another I2C bus"
                )
            self.smbus_only = True
            log.info("%s: SMBus-only adapter: frames go as SMBus I2C-block writes", self._where())

    def _write_error(self, error: OSError) -> HardwareError:
        if error.errno in NOT_SUPPORTED:
            return HardwareError(
                f"{self._where()}: this adapter cannot do plain I2C ({reason(error)}):"
                " an SMBus-only controller; bywire writes SMBus I2C-block frames where the"
                " adapter says so (I2C_FUNCS)"
            )
        if error.errno == errno.EBUSY:
            return HardwareError(f"{self._where()}: busy ({reason(error)})")
        return HardwareError(f"{self._where()}: no acknowledge ({reason(error)})")

    def _zero_all(self) -> None:
        for channel in dac6574.CHANNELS:
            self.write(dac6574.encode_write(channel, 0))

    def _release(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            bus.close()
