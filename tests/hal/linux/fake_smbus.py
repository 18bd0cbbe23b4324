"""An object with the smbus2 interface that records every I2C write as the bytes on the wire.

It answers as i2c-dev does: `funcs` as I2C_FUNCS gives them, `claim` as I2C_SLAVE (EBUSY when
`owner`, a kernel driver, is bound to the address), and an SMBus-only adapter (`smbus_only`:
the kernel's i2c-stub, Intel i801) refuses plain I2C with EOPNOTSUPP. tests/kernel runs the
same backend against the kernel's own i2c-stub and i2c-dev.
"""

from __future__ import annotations

import errno
from collections.abc import Sequence

from smbus2 import I2cFunc, i2c_msg

PLAIN_I2C = I2cFunc.I2C | I2cFunc.SMBUS_EMUL
SMBUS_ONLY = I2cFunc.SMBUS_BYTE_DATA | I2cFunc.SMBUS_WORD_DATA | I2cFunc.SMBUS_I2C_BLOCK


class RecordingSMBus:
    """`SMBus(path)` stand-in: `transfers` holds (address, bytes) of every write message."""

    def __init__(self, path: str, *, smbus_only: bool = False, owner: str | None = None) -> None:
        self.path = path
        self.transfers: list[tuple[int, bytes]] = []
        self.nak = False
        self.closed = 0
        self.smbus_only = smbus_only
        self.funcs = SMBUS_ONLY if smbus_only else PLAIN_I2C
        self.owner = owner
        self.claimed: int | None = None

    def claim(self, address: int) -> None:
        if self.owner is not None:
            raise OSError(errno.EBUSY, "Device or resource busy")
        self.claimed = address

    def i2c_rdwr(self, *messages: i2c_msg) -> None:
        if self.smbus_only:
            raise OSError(errno.EOPNOTSUPP, "Operation not supported")
        if self.nak:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        for message in messages:
            self.transfers.append((message.addr, bytes(message)))

    def write_i2c_block_data(self, i2c_addr: int, register: int, data: Sequence[int]) -> None:
        if self.nak:
            raise OSError(errno.ENXIO, "No such device or address")
        self.transfers.append((i2c_addr, bytes([register, *data])))

    def close(self) -> None:
        self.closed += 1
