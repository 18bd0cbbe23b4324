"""The CAN traffic of a simulated run: counted, and streamed to a log by python-can's writers.

The file is what a real logger on the robot's bus would record: every frame, timestamped with
the virtual time offset to the wall-clock start of the run (so tools show a sensible date),
marked Tx when the controller sent it and Rx otherwise.
"""

from __future__ import annotations

import importlib.util
import time
from collections import Counter
from pathlib import Path
from types import TracebackType
from typing import Any

import can

from bywire.errors import ConfigError
from bywire.hal.sim.can_bus import LoggedFrame
from bywire.hal.sim.world import CONTROLLER_NODE

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
    """A bus monitor writing each frame to `path`; use as a context manager around the run."""

    def __init__(
        self, path: Path, start_s: float, wall_start_s: float | None = None, channel: str = CHANNEL
    ) -> None:
        check_log_path(path)
        self.path = path
        self.frames = 0
        self._offset_s = (time.time() if wall_start_s is None else wall_start_s) - start_s
        self._channel = channel
        try:
            self._writer = WRITERS[path.suffix.lower()](path)
        except OSError as error:
            raise ConfigError(f"cannot write {path}: {error.strerror}") from error

    def __call__(self, frame: LoggedFrame) -> None:
        message = can.Message(
            timestamp=frame.time_s + self._offset_s,
            arbitration_id=frame.arbitration_id,
            data=frame.data,
            is_extended_id=False,
            is_rx=frame.sender != CONTROLLER_NODE,
            channel=self._channel,
        )
        self._writer.on_message_received(message)
        self.frames += 1

    def close(self) -> None:
        """Flush and close the file (BLF writes its header and object count here)."""
        self._writer.stop()

    def __enter__(self) -> CanLog:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()
