"""The CAN traffic of a simulated run: counted, and streamed to a log by python-can's writers.

The file is what a real logger on the robot's bus would record: every frame, timestamped with
the virtual time offset to the wall-clock start of the run (so tools show a sensible date),
marked Tx when the controller sent it and Rx otherwise.
"""

from __future__ import annotations

import contextlib
import importlib.util
import time
from collections import Counter
from pathlib import Path
from types import TracebackType
from typing import Any

import can

from bywire.errors import ConfigError
from bywire.hal.simulated.can_bus import LoggedFrame
from bywire.hal.simulated.world import CONTROLLER_NODE

WRITERS: dict[str, Any] = {
    ".blf": can.BLFWriter,
    ".asc": can.ASCWriter,
    ".log": can.CanutilsLogWriter,
    ".trc": can.TRCWriter,
    ".csv": can.CSVWriter,
    ".mf4": can.MF4Writer,  # needs asammdf (pip install 'bywire[mf4]')
}
FORMATS = "BLF, Vector ASC, candump -L, PEAK TRC, python-can CSV, ASAM MDF4"
CHANNEL = "can0"
TEXT_FORMATS = (".asc", ".log")
TAIL_BYTES = 1 << 16  # a log line is under 200 bytes


def _cut_to_last_line(path: Path) -> None:
    """Cut a text file back to the end of its last whole line (a failed write leaves half a
    line, which python-can's readers refuse)."""
    with path.open("r+b") as file:
        size = file.seek(0, 2)
        file.seek(max(size - TAIL_BYTES, 0))
        tail = file.read()
        end = tail.rfind(b"\n")
        file.truncate(size - len(tail) + end + 1 if end >= 0 else max(size - len(tail), 0))


def check_log_path(path: Path) -> None:
    """ConfigError unless the suffix names a format we write (and can: MF4 needs asammdf) and
    its folder exists."""
    suffix = path.suffix.lower()
    if suffix not in WRITERS:
        raise ConfigError(
            f"cannot write a CAN log as {path.name!r}: the suffix must be one of"
            f" {', '.join(WRITERS)} ({FORMATS})"
        )
    if suffix == ".mf4" and importlib.util.find_spec("asammdf") is None:
        raise ConfigError(
            "writing .mf4 needs the asammdf package: pip install 'bywire[mf4]' (or asammdf)"
        )
    if not path.parent.is_dir():
        raise ConfigError(f"cannot write {path}: folder {path.parent} does not exist")


class BusTally:
    """A bus monitor counting every frame that crosses the bus, by sending node."""

    def __init__(self) -> None:
        self.frames_by_sender: Counter[str] = Counter()

    def __call__(self, frame: LoggedFrame) -> None:
        self.frames_by_sender[frame.sender] += 1


class CanLog:
    """A bus monitor writing each frame to `path`; use as a context manager around the run.

    A write that fails (a full disk, an I/O error) ends the log, never the run: `failure` says
    where it stopped, once; the file is closed with what it holds (a text log cut back to its
    last whole line, so every reader opens it), and later frames are only counted (`dropped`).
    """

    def __init__(
        self, path: Path, start_s: float, wall_start_s: float | None = None, channel: str = CHANNEL
    ) -> None:
        check_log_path(path)
        self.path = path
        self.frames = 0
        self.dropped = 0
        self.failure: str | None = None
        self._offset_s = (time.time() if wall_start_s is None else wall_start_s) - start_s
        self._channel = channel
        try:
            self._writer = WRITERS[path.suffix.lower()](path)
        except OSError as error:
            raise ConfigError(f"cannot write {path}: {error.strerror}") from error

    def __call__(self, frame: LoggedFrame) -> None:
        if self.failure is not None:
            self.dropped += 1
            return
        message = can.Message(
            timestamp=frame.time_s + self._offset_s,
            arbitration_id=frame.arbitration_id,
            data=frame.data,
            is_extended_id=False,
            is_rx=frame.sender != CONTROLLER_NODE,
            channel=self._channel,
        )
        try:
            self._writer.on_message_received(message)
        except OSError as error:
            self._fail(error)
            self.dropped += 1
            return
        self.frames += 1

    def close(self) -> None:
        """Flush and close the file (BLF writes its header and object count here)."""
        if self.failure is None:
            try:
                self._writer.stop()
            except OSError as error:
                self._fail(error)

    def _fail(self, error: OSError) -> None:
        self.failure = (
            f"{self.path}: cannot write ({error.strerror or error}): the CAN log stops after"
            f" {self.frames} frames"
        )
        with contextlib.suppress(Exception):  # what it can still flush (BLF: its header)
            self._writer.stop()
        if self.path.suffix.lower() in TEXT_FORMATS:
            with contextlib.suppress(OSError):
                _cut_to_last_line(self.path)

    def __enter__(self) -> CanLog:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()
