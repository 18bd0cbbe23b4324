"""An object with the smbus2 interface that records every raw I2C transaction."""

from __future__ import annotations

import errno

from smbus2 import i2c_msg


class RecordingSMBus:
    """`SMBus(path)` stand-in: `transfers` holds (address, bytes) of every write message."""

    def __init__(self, path: str) -> None:
        self.path = path
        self.transfers: list[tuple[int, bytes]] = []
        self.nak = False
        self.closed = 0

    def i2c_rdwr(self, *messages: i2c_msg) -> None:
        if self.nak:
            raise OSError(errno.EREMOTEIO, "Remote I/O error")
        for message in messages:
            self.transfers.append((message.addr, bytes(message)))

    def close(self) -> None:
        self.closed += 1
