"""A python-can bus read on a thread of its own: frames queued for the monitor, and recorded.

``open_bus`` turns python-can's many failure modes into one HardwareError a user can act on (as
`bywire run` does: `hal.linux.can_open`); for socketcand it first checks that something listens,
instead of python-can's 10 s of retries, and for socketcan that the kernel has SocketCAN and the
interface is there and up.
"""

from __future__ import annotations

import contextlib
import queue
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import can

from bywire.background import OWNER
from bywire.canlog.write import WRITERS, check_log_path
from bywire.errors import ConfigError, HardwareError
from bywire.hal.linux.can_open import check_socketcan, open_error

RECEIVE_TIMEOUT_S = 0.1  # how often the reader looks at its stop flag
SILENT_S = 3.0  # no frame for this long: the connection is opened again
RETRY_S = 1.0  # how often a lost bus is opened again
CONNECT_TIMEOUT_S = 2.0
DEFAULT_BITRATE_BPS = 500_000  # Albert's bus: what `ip link … bitrate` is told in a hint


def open_bus(interface: str, channel: str, host: str, port: int, **options: Any) -> can.BusABC:
    """A python-can bus; host and port are used by ``socketcand`` only."""
    if interface == "socketcand":
        _check_listening(host, port)
        options = {**options, "host": host, "port": port}
    elif interface == "socketcan":
        check_socketcan(channel, int(options.get("bitrate", DEFAULT_BITRATE_BPS)))
    try:
        bus: can.BusABC = can.Bus(interface=interface, channel=channel, **options)
    except Exception as error:  # drivers raise anything, even NameError
        raise open_error(f"{interface} {channel}", interface, error) from error
    return bus


def _check_listening(host: str, port: int) -> None:
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S):
            pass
    except OSError as error:
        raise HardwareError(
            f"nothing answers on {host} port {port} ({error.strerror or error}): start the"
            f" simulator with `bywire sim --realtime --serve {port}` or socketcand on the robot"
        ) from error


class CanFeed:
    """Reads ``bus`` until ``stop()``; ``drain()`` hands over what arrived since the last call.

    With ``record``, every frame is also written to that file (BLF, ASC or candump -L by
    suffix, python-can's writers as ``bywire sim --log`` uses them), closed by ``stop()``.
    """

    def __init__(
        self,
        bus: can.BusABC,
        record: Path | None = None,
        reopen: Callable[[], can.BusABC] | None = None,
    ) -> None:
        self.bus = bus
        self.recorded = 0
        self.connection = "connected"
        """What the user is shown: connected, or lost (why) and reconnecting."""
        self.reconnects = 0
        self._reopen = reopen
        self._frames: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self._stopping = threading.Event()
        self._writer: Any = None
        if record is not None:
            check_log_path(record)
            try:
                self._writer = WRITERS[record.suffix.lower()](record)
            except OSError as error:
                raise ConfigError(f"cannot write {record}: {error.strerror}") from error
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start reading."""
        self._thread = OWNER.thread(self._read, name="bywire-monitor-can", stop=self._stopping.set)

    def stop(self) -> None:
        """Stop reading, close the recording and the bus."""
        self._stopping.set()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join()
        if self._writer is not None:
            self._writer.stop()
        with contextlib.suppress(Exception):  # already closed when the connection was lost
            self.bus.shutdown()

    def drain(self) -> list[can.Message]:
        """Every frame received since the last call, oldest first."""
        frames: list[can.Message] = []
        while True:
            try:
                frames.append(self._frames.get_nowait())
            except queue.Empty:
                return frames

    def _read(self) -> None:
        last_frame_s = time.monotonic()
        while not self._stopping.is_set():
            try:
                message = self.bus.recv(RECEIVE_TIMEOUT_S)
            except can.CanError as error:
                self._lost(" ".join(str(error).split())[:80] or type(error).__name__)
                last_frame_s = time.monotonic()
                continue
            if message is None:
                # A socketcand server that died leaves python-can returning nothing, forever:
                # silence this long (the robot reports at 50 Hz) means the link is to be redone.
                silent_s = time.monotonic() - last_frame_s
                if self._reopen is not None and silent_s >= SILENT_S:
                    self._lost(f"no frame for {silent_s:.0f} s")
                    last_frame_s = time.monotonic()
                continue
            last_frame_s = time.monotonic()
            if message.is_error_frame:
                continue
            self._frames.put(message)
            if self._writer is not None:
                self._writer.on_message_received(message)
                self.recorded += 1

    def _lost(self, reason: str) -> None:
        """The bus went away: say so, and (with `reopen`) open it again until it comes back or
        the feed stops. What arrived so far stays; the recording goes on after the gap."""
        if self._reopen is None:
            self.connection = f"lost ({reason})"
            self._stopping.wait()
            return
        self.connection = f"lost ({reason}); reconnecting every {RETRY_S:g} s"
        with contextlib.suppress(Exception):  # a dead bus may fail to close, too
            self.bus.shutdown()
        while not self._stopping.wait(RETRY_S):
            try:
                self.bus = self._reopen()
            except HardwareError as error:
                self.connection = f"lost ({error}); retrying every {RETRY_S:g} s"
                continue
            self.reconnects += 1
            self.connection = f"connected (reconnected {self.reconnects}×)"
            return
