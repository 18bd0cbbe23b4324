"""Read a CAN log (BLF, Vector ASC, candump -L) with python-can and decode it with a DBC.

The result is one time series per signal, named ``Message.signal``, in seconds from the log's
first frame: what `bywire plot` draws. Frames the DBC does not know (other nodes' traffic) are
counted and skipped; so are frames it cannot decode (a wrong length).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

import can
import cantools
from can.io.blf import BLFParseError
from cantools.database.can import Database, Message

from bywire.errors import ConfigError

SUFFIXES = (".blf", ".asc", ".log")
FORMATS = "BLF, Vector ASC or candump -L"
_READ_ERRORS = (ValueError, EOFError, struct.error, BLFParseError, can.CanError)


@dataclass(frozen=True, slots=True)
class Signal:
    """One signal over time: `times_s` from the log's first frame, `values` as decoded."""

    times_s: tuple[float, ...]
    values: tuple[float, ...]


@dataclass(slots=True)
class DecodedLog:
    """Every signal of every known frame in a log, and what was left out."""

    signals: dict[str, Signal] = field(default_factory=dict)
    frames: int = 0
    unknown_frames: int = 0
    undecodable_frames: int = 0
    duration_s: float = 0.0

    def signal(self, name: str) -> Signal:
        """``Message.signal``; empty when the log has none."""
        return self.signals.get(name, Signal((), ()))


def check_log_suffix(path: Path) -> None:
    """ConfigError unless the name ends in a suffix python-can reads as a CAN log we write."""
    if path.suffix.lower() not in SUFFIXES:
        raise ConfigError(
            f"cannot read {path.name!r} as a CAN log: the suffix must be one of"
            f" {', '.join(SUFFIXES)} ({FORMATS})"
        )


def read_messages(path: Path) -> list[can.Message]:
    """Every data frame in the log, in file order; ConfigError when it cannot be read."""
    check_log_suffix(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such CAN log")
    try:
        messages = list(can.LogReader(str(path)))
    except OSError as error:
        raise ConfigError(f"cannot read {path}: {error.strerror or error}") from error
    except _READ_ERRORS as error:
        reason = " ".join(str(error).split()) or type(error).__name__
        raise ConfigError(f"{path}: not a readable {path.suffix} CAN log: {reason}") from error
    return [m for m in messages if not (m.is_error_frame or m.is_remote_frame)]


def decode_messages(messages: list[can.Message], database: Database) -> DecodedLog:
    """Decode every frame the DBC knows; times relative to the first frame of the log."""
    log = DecodedLog(frames=len(messages))
    if not messages:
        return log
    start_s = messages[0].timestamp
    series: dict[str, tuple[list[float], list[float]]] = {}
    by_id = {message.frame_id: message for message in database.messages}
    for frame in messages:
        message = by_id.get(frame.arbitration_id)
        if message is None:
            log.unknown_frames += 1
            continue
        values = _decode(message, bytes(frame.data))
        if values is None:
            log.undecodable_frames += 1
            continue
        time_s = frame.timestamp - start_s
        for name, value in values.items():
            times, numbers = series.setdefault(f"{message.name}.{name}", ([], []))
            times.append(time_s)
            numbers.append(value)
    log.duration_s = messages[-1].timestamp - start_s
    log.signals = {name: Signal(tuple(t), tuple(v)) for name, (t, v) in series.items()}
    return log


def _decode(message: Message, data: bytes) -> dict[str, float] | None:
    """The frame's signals as numbers, or None when the payload does not fit the message."""
    if len(data) != message.length:
        return None
    try:
        values = message.decode(data, decode_choices=False)
    except (ValueError, cantools.errors.Error):
        return None
    if not isinstance(values, dict):
        return None
    # ints stay ints: a 64-bit flag field does not fit a float's 53-bit mantissa
    return {name: v for name, v in values.items() if isinstance(v, int | float)}


def read_can_log(path: Path, database: Database) -> DecodedLog:
    """Read and decode a CAN log; ConfigError when it is unreadable or holds nothing to decode."""
    log = decode_messages(read_messages(path), database)
    if not log.signals:
        raise ConfigError(
            f"{path}: nothing to plot: {log.frames} frames, none of them a message of the DBC"
        )
    return log
