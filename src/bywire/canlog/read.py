"""Read a CAN log with the field's readers and decode it with a DBC.

python-can's readers take BLF, Vector ASC, PEAK TRC, ASAM MDF4 (with asammdf), python-can's CSV
and SQLite, and `candump -l`/`-L` logs; cantools' log parser takes candump's text output
(`candump can0` and its `-ta`, `-tz`, `-td`, `-tA` timestamps). The result is one time series
per signal, named ``Message.signal``, in seconds from the log's first frame: what `bywire plot`
draws. Frames the DBC does not know (other nodes' traffic) are counted and skipped; so are
frames it cannot decode (a wrong length).

A log cut short is read up to the cut: a text log whose last line has no newline loses that
line, a log with an unreadable entry stops before it, and `ReadLog.stopped` says where. Reasons
are given in the user's terms (a cut file, a malformed line), never as a Python exception.
"""

from __future__ import annotations

import datetime
import importlib.util
import io
import itertools
import re
import sqlite3
import struct
import zlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import cantools
from can.io.blf import BLFParseError
from cantools.database.can import Database, Message
from cantools.logreader import DataFrame, Parser, TimestampFormat

from bywire.errors import ConfigError

PYTHON_CAN_SUFFIXES = (".blf", ".asc", ".trc", ".mf4", ".csv", ".db")
CANDUMP_SUFFIXES = (".log", ".txt", ".candump")
SUFFIXES = (*PYTHON_CAN_SUFFIXES, *CANDUMP_SUFFIXES)
FORMATS = (
    "BLF, Vector ASC, PEAK TRC, ASAM MDF4, python-can CSV or SQLite, candump -l/-L,"
    " or candump's text output"
)
_TEXT_SUFFIXES = (".asc", ".trc", ".csv", *CANDUMP_SUFFIXES)
_DAMAGED = (struct.error, EOFError, BLFParseError, zlib.error, sqlite3.DatabaseError)
_READ_ERRORS = (ValueError, IndexError, KeyError, *_DAMAGED, can.CanError)
# `candump -l` / `-L`: "(1594172461.968006) can0 123#1122334455667788", read by python-can.
_CANDUMP_L = re.compile(r"\s*\(\d+\.\d+\)\s+\S+\s+[0-9A-Fa-f]+#")
# The "[8]" of candump's text formats: the data must hold that many bytes.
_TEXT_DLC = re.compile(r"\s\[(\d+)\]\s")


@dataclass(frozen=True, slots=True)
class Signal:
    """One signal over time: `times_s` from the log's first frame, `values` as decoded."""

    times_s: tuple[float, ...]
    values: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class ReadLog:
    """The data frames of a log in file order, and whether (and where) reading stopped early.

    `timed` is False for formats without timestamps (`candump can0`): each frame's timestamp is
    then its number in the log, from 0.
    """

    messages: list[can.Message]
    timed: bool = True
    stopped: str | None = None


@dataclass(slots=True)
class DecodedLog:
    """Every signal of every known frame in a log, and what was left out."""

    signals: dict[str, Signal] = field(default_factory=dict)
    frames: int = 0
    unknown_frames: int = 0
    undecodable_frames: int = 0
    duration_s: float = 0.0
    timed: bool = True
    stopped: str | None = None

    def signal(self, name: str) -> Signal:
        """``Message.signal``; empty when the log has none."""
        return self.signals.get(name, Signal((), ()))


def check_log_suffix(path: Path) -> None:
    """ConfigError unless the name ends in a suffix of a CAN log format we can read."""
    if path.suffix.lower() not in SUFFIXES:
        raise ConfigError(
            f"cannot read {path.name!r} as a CAN log: the suffix must be one of"
            f" {', '.join(SUFFIXES)} ({FORMATS})"
        )


def read_messages(path: Path) -> list[can.Message]:
    """Every data frame in the log, in file order; ConfigError when it cannot be read."""
    return read_log(path).messages


def read_log(path: Path) -> ReadLog:
    """The log's data frames (error and remote frames left out), read up to any cut or damage.

    ConfigError when the file is missing, of an unknown kind, or yields not a single frame.
    """
    check_log_suffix(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such CAN log")
    suffix = path.suffix.lower()
    try:
        if suffix in _TEXT_SUFFIXES:
            text, cut = _complete_lines(path)
            if suffix in CANDUMP_SUFFIXES and not _CANDUMP_L.match(_first_line(text)):
                log = _read_candump_text(path, text)
            else:
                kind = ".log" if suffix in CANDUMP_SUFFIXES else suffix  # candump -l/-L
                log = _read_python_can(path, lambda: _reader(kind, io.StringIO(text)))
        else:
            log = _read_python_can(path, lambda: _reader(suffix, str(path)))
            cut = _blf_cut(path) if suffix == ".blf" else None
    except OSError as error:
        raise ConfigError(f"cannot read {path}: {error.strerror or error}") from error
    stopped = log.stopped or cut
    messages = [m for m in log.messages if not (m.is_error_frame or m.is_remote_frame)]
    return ReadLog(messages, log.timed, stopped)


def _reader(suffix: str, source: str | io.StringIO) -> Iterable[can.Message]:
    if suffix == ".mf4" and importlib.util.find_spec("asammdf") is None:
        raise ConfigError("reading .mf4 needs the asammdf package: pip install asammdf")
    reader_class: Any = can.io.player.MESSAGE_READERS[suffix]  # each takes a path or a text file
    reader: Iterable[can.Message] = reader_class(source)
    return reader


def _complete_lines(path: Path) -> tuple[str, str | None]:
    """The text up to its last newline, and a note when a last line without one was dropped."""
    text = path.read_text(encoding="utf-8", errors="replace")
    if not text or text.endswith("\n"):
        return text, None
    complete = text[: text.rfind("\n") + 1]
    number = complete.count("\n") + 1
    return complete, (
        f"line {number} is cut short (the file ends without a newline):"
        f" read the {number - 1} lines before it"
    )


def _first_line(text: str) -> str:
    return next((line for line in text.splitlines() if line.strip()), "")


def _blf_cut(path: Path) -> str | None:
    """A note when a BLF file is shorter than its header says (a capture cut short)."""
    try:
        with can.BLFReader(str(path)) as reader:
            expected = int(reader.file_size)
    except (*_READ_ERRORS, OSError):
        return None
    size = path.stat().st_size
    if not size < expected:
        return None
    return f"the file is cut short ({size} of the {expected} bytes its header announces)"


def _read_python_can(path: Path, open_reader: Callable[[], Iterable[can.Message]]) -> ReadLog:
    """Frames up to the first entry the reader fails on (readers open the file when created)."""
    messages: list[can.Message] = []
    try:
        for message in open_reader():
            messages.append(message)
    except ConfigError:
        raise
    except _READ_ERRORS as error:
        reason = _plain_reason(error, path)
        if not messages:
            raise ConfigError(f"{path}: not a readable {path.suffix} CAN log: {reason}") from error
        stopped = f"stopped after frame {len(messages)}: {reason}"
        return ReadLog(messages, stopped=stopped)
    return ReadLog(messages)


def _plain_reason(error: BaseException, path: Path) -> str:
    """What went wrong, in a user's terms rather than the reader's exception text."""
    if isinstance(error, _DAMAGED):
        return (
            f"the data breaks off inside a record (a cut or damaged {path.suffix} file,"
            " or not that format)"
        )
    return f"an entry that is not {path.suffix} CAN log data"


# --- candump's text formats (cantools' parser) ----------------------------------------------


def _read_candump_text(path: Path, text: str) -> ReadLog:
    """`candump can0` with or without -ta/-tz/-td/-tA; stops at the first line it cannot read."""
    parser = Parser(tz=datetime.UTC)
    frames: list[DataFrame] = []
    stopped = None
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip() or "ERRORFRAME" in line:
            continue
        frame = parser.parse(line)
        if frame is None or not _dlc_matches(line, frame):
            shown = line.strip() if len(line.strip()) <= 60 else line.strip()[:57] + "..."
            if not frames:
                raise ConfigError(
                    f"{path}: line {number} is not a CAN frame of candump's text output"
                    f" ({shown!r}); {FORMATS} can be read"
                )
            stopped = f"line {number} is not a candump frame ({shown!r}): read the lines before it"
            break
        frames.append(frame)
    timed = bool(frames) and frames[0].timestamp_format is not TimestampFormat.MISSING
    seconds = _seconds(frames) if timed else [float(index) for index in range(len(frames))]
    messages = [
        can.Message(
            timestamp=time_s,
            arbitration_id=frame.frame_id,
            is_extended_id=frame.is_extended_frame,
            is_remote_frame=frame.is_remote_frame,
            data=frame.data,
            channel=frame.channel,
        )
        for frame, time_s in zip(frames, seconds, strict=True)
    ]
    return ReadLog(messages, timed, stopped)


def _dlc_matches(line: str, frame: DataFrame) -> bool:
    """candump prints "[8]" then 8 bytes: fewer means a cut or mangled line."""
    match = _TEXT_DLC.search(line)
    return frame.is_remote_frame or match is None or int(match[1]) == len(frame.data)


def _seconds(frames: list[DataFrame]) -> list[float]:
    """Seconds: absolute (-ta, -tA) and relative to the first frame (-tz) as they are, deltas to
    the previous frame (-td) summed.

    -tz and -td look alike ("(000.010000)"); -tz times grow with every frame (two frames in one
    microsecond are rare), -td times stay near the bus period, up and down. So relative times of
    which at least a quarter do not grow are read as deltas.
    """
    values = list(_raw_seconds(frames))
    relative = frames[0].timestamp_format is TimestampFormat.RELATIVE
    steady = sum(later <= earlier for earlier, later in itertools.pairwise(values))
    if relative and steady * 4 >= len(values) - 1 > 0:
        total, summed = 0.0, []
        for delta in values:
            total += delta
            summed.append(total)
        return summed
    return values


def _raw_seconds(frames: list[DataFrame]) -> Iterator[float]:
    for frame in frames:
        stamp = frame.timestamp
        if isinstance(stamp, datetime.timedelta):
            yield stamp.total_seconds()
        elif isinstance(stamp, datetime.datetime):
            yield stamp.timestamp()
        else:
            yield 0.0


# --- decoding ---------------------------------------------------------------------------------


def decode_messages(
    messages: list[can.Message], database: Database, *, timed: bool = True
) -> DecodedLog:
    """Decode every frame the DBC knows; times relative to the first frame of the log."""
    log = DecodedLog(frames=len(messages), timed=timed)
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
    # ints stay ints: a 64-bit signal does not fit a float's 53-bit mantissa
    return {name: v for name, v in values.items() if isinstance(v, int | float)}


def read_can_log(path: Path, database: Database) -> DecodedLog:
    """Read and decode a CAN log; ConfigError when it is unreadable or holds nothing to decode."""
    read = read_log(path)
    log = decode_messages(read.messages, database, timed=read.timed)
    log.stopped = read.stopped
    if not log.signals:
        raise ConfigError(
            f"{path}: nothing to plot: {log.frames} frames, none of them a message of the DBC"
        )
    return log
