"""The RC receiver on a real tty: a pty pair fed by the simulated transmitter at 115200 baud.

The port is a symlink to the pty's slave, as `/dev/serial/by-id/...` is to a USB adapter, so a
test can unplug the line (close the pty, remove the link) and plug a new one in under the same
name. The simulated transmitter (real IBUS frames every 7.7 ms) runs on a real-time clock in a
thread; each frame is written to the master a few bytes at a time, when a 115200-baud line
would have delivered them.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
import tty
from pathlib import Path

from bywire.hal.simulated.clock import RealtimeClock
from bywire.hal.simulated.rc_transmitter import SimRcTransmitter
from bywire.hal.simulated.uart import BITS_PER_BYTE_8N1
from bywire.model import ControlMode, Gear
from bywire.protocol import ibus

BYTE_TIME_S = BITS_PER_BYTE_8N1 / ibus.BAUD_RATE
CHUNK_BYTES = 4


class PtyRcLine:
    """A plugged-in RC receiver at `link`; `transmitter` moves its sticks and switches."""

    def __init__(self, link: Path) -> None:
        self.link = link
        self._master: int | None = None
        self._slave: int | None = None
        self._lock = threading.Lock()
        self.bytes_written = 0
        self.plug()
        self.clock = RealtimeClock()
        # SimRcTransmitter's uart is typed as SimUart; this line offers the same transmit()
        self.transmitter = SimRcTransmitter(self.clock, self)  # type: ignore[arg-type]
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pty-rc", daemon=True)

    def start(self) -> None:
        """The receiver sends a frame every period from now."""
        self.transmitter.start()
        self._thread.start()

    @classmethod
    def at_rest(cls, link: Path) -> PtyRcLine:
        """A receiver sending from now, its transmitter's switch at STOP in gear forward: the
        operator's starting position in the tests of `bywire run`."""
        line = cls(link)
        line.transmitter.set_mode(ControlMode.STOP)
        line.transmitter.set_gear(Gear.FORWARD)
        line.start()
        return line

    def transmit(self, data: bytes, start_s: float | None = None) -> float:
        """Called by the transmitter: put `data` on the line at 115200 baud from `start_s`."""
        begin_s = self.clock.now() if start_s is None else start_s
        for offset in range(0, len(data), CHUNK_BYTES):
            chunk = data[offset : offset + CHUNK_BYTES]
            arrival_s = begin_s + (offset + len(chunk)) * BYTE_TIME_S
            delay_s = arrival_s - self.clock.now()
            if delay_s > 0:
                time.sleep(delay_s)
            self.write(chunk)
        return begin_s + len(data) * BYTE_TIME_S

    def write(self, data: bytes) -> None:
        """Raw bytes on the line now (dropped while unplugged or when nobody reads)."""
        with self._lock:
            if self._master is None:
                return
            with contextlib.suppress(BlockingIOError, OSError):
                self.bytes_written += os.write(self._master, data)

    def unplug(self) -> None:
        """The adapter is pulled: the tty hangs up and its name disappears."""
        with self._lock:
            for fd in (self._master, self._slave):
                if fd is not None:
                    os.close(fd)
            self._master = self._slave = None
            self.link.unlink(missing_ok=True)

    def plug(self) -> None:
        """A (new) adapter appears under the same name."""
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        temporary = self.link.with_name(self.link.name + ".new")
        temporary.unlink(missing_ok=True)
        temporary.symlink_to(os.ttyname(slave))
        with self._lock:
            self._master, self._slave = master, slave
            os.replace(temporary, self.link)

    def close(self) -> None:
        self._stopping.set()
        self.transmitter.stop()
        if self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self.unplug()

    def _run(self) -> None:
        while not self._stopping.is_set():
            self.clock.advance(0.02)
