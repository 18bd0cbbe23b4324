"""The RC receiver's UART through pyserial: a reader thread fills a buffer and wakes the clock.

115200 8N1 (IBUS). The thread blocks in `read(in_waiting or 1)` with a short timeout, so a byte
is handed over as soon as the driver has it, and `read_available` never blocks. When the port
vanishes (a USB adapter unplugged, EIO) the fault is logged and kept in `fault` (and `link`,
which the runtime reports as IBUS_PORT_FAILED), the RC timeout puts the robot in STOP, and the
thread re-opens the port when it comes back.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import termios
import threading
from collections.abc import Callable

import serial

from bywire.background import OWNER
from bywire.errors import HardwareError
from bywire.hal.linux.device_errors import device_error, reason
from bywire.hal.ports import LinkState

log = logging.getLogger(__name__)
READ_TIMEOUT_S = 0.05  # how long a read waits before the thread checks for close()
REOPEN_PERIOD_S = 0.5
MISSING_HINT = "enable the UART (Raspberry Pi: enable_uart=1, serial console off) or fix rc.port"


class PyserialStream:
    """A `ByteStream` on a serial device; `wake` is called (from the thread) when bytes arrive."""

    def __init__(
        self,
        port: str,
        wake: Callable[[], None],
        *,
        baud: int = 115_200,
        reopen_period_s: float = REOPEN_PERIOD_S,
        now_s: Callable[[], float] | None = None,
    ) -> None:
        """`now_s`: the loop's clock, read by the thread as each chunk arrives (None: no
        arrival stamps; the reader then takes the time it read the bytes)."""
        self.port = port
        self._now_s = now_s
        self._buffer_arrived_at_s: float | None = None
        self._arrived_at_s: float | None = None
        self._baud = baud
        self._wake = wake
        self._reopen_period_s = reopen_period_s
        self._buffer = bytearray()
        self._lock = threading.Lock()
        self._closing = threading.Event()
        self.fault: HardwareError | None = None
        """Why the port is gone, None while it works."""
        self.disconnects = 0
        """Reads that failed: each one lost the port."""
        self.reopens = 0
        self.reopen_failures = 0
        self.bytes_received = 0
        self._serial: serial.Serial | None = self._open()
        self._thread = OWNER.thread(self._run, name=f"bywire-rc-uart {port}", stop=self.close)

    def read_available(self) -> bytes:
        with self._lock:
            data = bytes(self._buffer)
            self._buffer.clear()
            if data:
                self._arrived_at_s = self._buffer_arrived_at_s
        return data

    @property
    def arrived_at_s(self) -> float | None:
        """When the thread received the newest chunk the last read returned (None without a
        clock)."""
        return self._arrived_at_s

    @property
    def link(self) -> LinkState:
        """Down from a failed read until the port is open again."""
        return LinkState(
            down=self.fault is not None,
            reopen_failures=self.reopen_failures,
            receive_failures=self.disconnects,
        )

    @property
    def connected(self) -> bool:
        """True while the port is open and readable."""
        return self._serial is not None and self.fault is None

    def close(self) -> None:
        """Stop the thread and close the port; safe to call again."""
        if self._closing.is_set():
            return
        self._closing.set()
        port = self._serial
        if port is not None:
            port.cancel_read()
        self._thread.join(timeout=2.0)
        self._close_port()

    def _open(self) -> serial.Serial:
        try:
            port = serial.Serial(
                self.port,
                self._baud,
                bytesize=serial.EIGHTBITS,
                parity=serial.PARITY_NONE,
                stopbits=serial.STOPBITS_ONE,
                timeout=READ_TIMEOUT_S,
                exclusive=True,
            )
        except serial.SerialException as error:
            raise _open_error(self.port, error) from error
        except termios.error as error:  # pyserial lets the tty's own ioctls' errors through
            raise _open_error(self.port, serial.SerialException(*error.args)) from error
        # Not every tty has ASYNC_LOW_LATENCY (a pty, some USB adapters): then it reads as is.
        with contextlib.suppress(OSError, ValueError, AttributeError):
            port.set_low_latency_mode(True)
        return port

    def _run(self) -> None:
        while not self._closing.is_set():
            port = self._serial
            if port is None:
                self._reopen()
                continue
            try:
                data = port.read(port.in_waiting or 1)
            except (serial.SerialException, OSError, TypeError) as error:
                self._lost(error)
                continue
            if data:
                arrived_at_s = None if self._now_s is None else self._now_s()
                with self._lock:
                    self._buffer.extend(data)
                    self._buffer_arrived_at_s = arrived_at_s
                self.bytes_received += len(data)
                self._wake()

    def _lost(self, error: BaseException) -> None:
        if self._closing.is_set():
            return
        self.fault = HardwareError(f"RC receiver: {self.port} lost: {reason(error)}")
        self.disconnects += 1
        log.warning("%s; re-opening every %.1f s", self.fault, self._reopen_period_s)
        self._close_port()

    def _reopen(self) -> None:
        if self._closing.wait(self._reopen_period_s):
            return
        try:
            self._serial = self._open()
        except HardwareError:
            self.reopen_failures += 1
            return
        self.fault = None
        self.reopens += 1
        log.warning("RC receiver: %s is back", self.port)

    def _close_port(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            with contextlib.suppress(OSError, serial.SerialException):  # already gone
                port.close()


def _open_error(path: str, error: serial.SerialException) -> HardwareError:
    number = error.errno if isinstance(error.errno, int) else None
    if number == errno.EWOULDBLOCK or "lock" in str(error).lower():
        return HardwareError(
            f"RC receiver: {path} is in use by another process (a serial console, getty,"
            " or another bywire?)"
        )
    if number is None:
        return HardwareError(f"RC receiver: cannot open {path}: {error}")
    os_error = OSError(number, os.strerror(number))
    return device_error("RC receiver", path, os_error, group="dialout", missing=MISSING_HINT)
