"""Where the view's bytes come from: the RC receiver's serial line, or the simulated transmitter.

The serial line is opened as `bywire run` opens it (`hal.linux.serial_pyserial.PyserialStream`:
115200 8N1, exclusive, re-opened when it comes back), so a port in use, missing or not
permitted is the same one line. The simulated transmitter (`rc.sweep`) runs on a virtual clock:
paced by the wall clock for the live view, as fast as possible for a snapshot.
"""

from __future__ import annotations

import time
from typing import Protocol

from bywire.hal.linux.serial_pyserial import PyserialStream


class ByteSource(Protocol):
    """An IBUS byte stream and its clock."""

    name: str
    """What the view calls it (the port, or the simulator)."""

    def read(self) -> bytes:
        """The bytes that arrived since the last read (never blocks)."""
        ...

    def now(self) -> float:
        """Seconds on the source's clock."""
        ...

    def wait(self, duration_s: float) -> None:
        """Let `duration_s` pass on the source's clock."""
        ...

    @property
    def problem(self) -> str | None:
        """What is wrong with the source now (a lost port), None while it works."""
        ...

    def close(self) -> None: ...


class SerialSource:
    """The RC receiver's UART, through the same pyserial reader `bywire run` uses."""

    def __init__(self, port: str, baud: int) -> None:
        self.name = f"{port} ({baud} 8N1)"
        self._stream = PyserialStream(port, _no_wake, baud=baud)

    def read(self) -> bytes:
        return self._stream.read_available()

    def now(self) -> float:
        return time.monotonic()

    def wait(self, duration_s: float) -> None:
        time.sleep(duration_s)

    @property
    def problem(self) -> str | None:
        fault = self._stream.fault
        return None if fault is None else f"{fault}; re-opening"

    def close(self) -> None:
        self._stream.close()


def _no_wake() -> None:
    """The view polls the port; nothing waits to be woken."""
