"""A python-can bus read on a thread of its own: frames queued for the monitor, and recorded.

``open_bus`` turns python-can's many failure modes into one HardwareError a user can act on; for
socketcand it first checks that something listens, instead of python-can's 10 s of retries.
"""

from __future__ import annotations

import queue
import socket
import threading
from pathlib import Path
from typing import Any

import can

from bywire.errors import ConfigError, HardwareError
from bywire.sim.canlog import WRITERS, check_log_path

RECEIVE_TIMEOUT_S = 0.1  # how often the reader looks at its stop flag
CONNECT_TIMEOUT_S = 2.0


def open_bus(interface: str, channel: str, host: str, port: int, **options: Any) -> can.BusABC:
    """A python-can bus; host and port are used by ``socketcand`` only."""
    if interface == "socketcand":
        _check_listening(host, port)
        options = {**options, "host": host, "port": port}
    try:
        bus: can.BusABC = can.Bus(interface=interface, channel=channel, **options)
    except (can.CanError, OSError, ValueError, ImportError) as error:
        raise HardwareError(f"cannot open {interface} channel {channel}: {error}") from error
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

    def __init__(self, bus: can.BusABC, record: Path | None = None) -> None:
        self.bus = bus
        self.recorded = 0
        self._frames: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self._stopping = threading.Event()
        self._writer: Any = None
        if record is not None:
            check_log_path(record)
            try:
                self._writer = WRITERS[record.suffix.lower()](record)
            except OSError as error:
                raise ConfigError(f"cannot write {record}: {error.strerror}") from error
        self._thread = threading.Thread(target=self._read, name="can-feed", daemon=True)

    def start(self) -> None:
        """Start reading."""
        self._thread.start()

    def stop(self) -> None:
        """Stop reading, close the recording and the bus."""
        self._stopping.set()
        if self._thread.is_alive():
            self._thread.join()
        if self._writer is not None:
            self._writer.stop()
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
        while not self._stopping.is_set():
            try:
                message = self.bus.recv(RECEIVE_TIMEOUT_S)
            except can.CanError:
                return  # the far end went away; what arrived so far stays
            if message is None or message.is_error_frame:
                continue
            self._frames.put(message)
            if self._writer is not None:
                self._writer.on_message_received(message)
                self.recorded += 1
