"""Typed CAN codec on top of cantools: model values <-> (frame id, payload), checked as a whole.

``albert.dbc`` (package data) is the single source of truth; it is loaded once, strictly. Each
message is named like its ``bywire.model`` class and each signal like the class field, so the
codec needs no mapping table. Pure: no I/O besides reading the packaged file, no clock.

Every command frame (higher-level computer -> controller) is protected the same way::

    byte  0 .. n-3          n-2                        n-1          (n = DLC, 3 or 8)
         +---------------+--------------------------+------------+
         | signals       | bits 7-4: signals        | CRC-8      |
         |               | bits 3-0: rolling counter|            |
         +---------------+--------------------------+------------+
    CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, final xor 0xFF, no reflection, check 0x4B) over:
        id & 0xFF, id >> 8, byte 0, byte 1, ..., byte n-2

The id bytes go into the CRC, as AUTOSAR E2E does with its Data ID, so a frame delivered under
another id fails the check. ``decode_command`` checks, in this order: known command id, length
(= DBC length), CRC, counter (previous + 1 mod 16 once a previous one is known), raw value ranges.
Any failure raises ``CommandRejected`` and nothing is returned: no partial update. Reports carry
no counter or CRC; their encoder saturates every value at the signal's range.

The codec is a pure function of immutable values, so it remembers its latest results: a robot
sends and receives the same few frames over and over (the counter wraps at 16; the values change
far more slowly than 50 times a second), and cantools' encode and decode are the costly part.
"""

from __future__ import annotations

import enum
from functools import cache, lru_cache
from importlib import resources
from pathlib import Path
from typing import cast

import cantools
from cantools.database.can import Database, Message

from bywire.command_table import COMMAND_TYPES
from bywire.errors import BywireError, FrameError
from bywire.model import REPORT_TYPES, Command, Report
from bywire.protocol import dbc_values
from bywire.protocol.crc8 import crc8

COUNTER_MODULUS = 16
DBC_RESOURCE = "albert.dbc"
CODEC_CACHE_SIZE = 512  # frames remembered per direction: every counter value of a few commands


class DbcError(BywireError, ValueError):
    """A DBC file cannot be read, parsed strictly, or breaks the protocol's conventions."""


class RejectReason(enum.Enum):
    """Why a command frame was rejected, in the order the checks run."""

    UNKNOWN_ID = "unknown command id"
    LENGTH = "wrong length"
    CHECKSUM = "bad CRC"
    COUNTER = "repeated or skipped counter"
    RANGE = "value out of range"


class CommandRejected(FrameError):  # noqa: N818 -- a verdict on a frame, not a bug
    """A command frame failed a check and was rejected as a whole.

    ``counter`` is the received rolling counter when the frame passed its CRC check (COUNTER and
    RANGE rejections), else None: a corrupt frame's counter must not be used to resynchronise.
    """

    def __init__(
        self, reason: RejectReason, frame_id: int, counter: int | None = None, detail: str = ""
    ) -> None:
        self.reason = reason
        self.frame_id = frame_id
        self.counter = counter
        suffix = f": {detail}" if detail else ""
        super().__init__(f"CAN frame 0x{frame_id:03X} rejected, {reason.value}{suffix}")


# --- the database -----------------------------------------------------------------------------


def load_database(path: Path) -> Database:
    """Load a DBC file strictly; raises DbcError with a one-line reason a user can act on."""
    try:
        loaded = cantools.database.load_file(path, database_format="dbc", strict=True)
    except (OSError, UnicodeDecodeError, cantools.errors.Error) as error:
        reason = " ".join(str(error).split())  # one line, whatever cantools quotes from the file
        raise DbcError(f"cannot load {path}: {reason}") from error
    return _as_can_database(loaded, str(path))


def load_user_database(path: Path) -> tuple[Database, str | None]:
    """A DBC a user brings, for the tools that only read it (show, plot): strictly when it can
    be, else as leniently as cantools loads without ``--strict`` (real-car DBCs such as
    opendbc's vw_mqb.dbc declare overlapping signals). Returns the database and, when it was
    loaded leniently, the strict check's reason. DbcError when it cannot be loaded at all.
    """
    try:
        return load_database(path), None
    except DbcError as strict_error:
        try:
            loaded = cantools.database.load_file(path, database_format="dbc", strict=False)
        except (OSError, UnicodeDecodeError, cantools.errors.Error):
            raise strict_error from None
        reason = str(strict_error).removeprefix(f"cannot load {path}: ")
        return _as_can_database(loaded, str(path)), reason


@cache
def database() -> Database:
    """The packaged CAN database (``albert.dbc``), loaded once, strictly, conventions checked.

    One shared object: treat it as read-only.
    """
    text = resources.files("bywire.protocol").joinpath(DBC_RESOURCE).read_text(encoding="utf-8")
    loaded = _as_can_database(cantools.database.load_string(text, "dbc", strict=True), DBC_RESOURCE)
    for kind in COMMAND_TYPES:
        _check_protection_layout(loaded.get_message_by_name(kind.__name__))
    return loaded


def _as_can_database(loaded: object, origin: str) -> Database:
    if not isinstance(loaded, Database):
        raise DbcError(f"{origin} is not a CAN database")
    return loaded


def _check_protection_layout(message: Message) -> None:
    """The codec relies on the CRC in the last byte and the counter in the low nibble before it."""
    crc = message.get_signal_by_name("crc")
    counter = message.get_signal_by_name("counter")
    last_bit = 8 * (message.length - 1)
    if (crc.start, crc.length, counter.start, counter.length) != (last_bit, 8, last_bit - 8, 4):
        raise DbcError(f"{message.name}: crc must fill the last byte, counter bits 0-3 before it")


# --- lookups for the runtime and the tools ----------------------------------------------------


def command_ids() -> tuple[int, ...]:
    """Frame ids of the commands (higher-level computer -> controller), highest priority first."""
    return tuple(sorted(frame_id(kind) for kind in COMMAND_TYPES))


def command_period_s() -> float:
    """The commands' one period (their ``GenMsgCycleTime``): the higher-level computer sends every
    command each period, and every tool that sends or fakes them keeps it."""
    periods = {period_s(frame) for frame in command_ids()}
    if len(periods) != 1:
        raise DbcError(f"the commands' GenMsgCycleTime differ ({sorted(periods)} s): give them one")
    return periods.pop()


def received_ids() -> tuple[int, ...]:
    """Every id the controller listens to: the commands and their SecOC cryptographic PDUs
    (every message the higher-level computer sends), highest priority first."""
    return tuple(sorted(m.frame_id for m in database().messages if m.senders == ["HLC"]))


def report_ids() -> tuple[int, ...]:
    """Frame ids of the reports (controller -> higher-level computer), highest priority first."""
    return tuple(sorted(frame_id(kind) for kind in REPORT_TYPES))


def frame_id(kind: type[Command] | type[Report]) -> int:
    """The frame id of a command or report type, e.g. ``frame_id(MovementCommand)``."""
    frame: int = database().get_message_by_name(kind.__name__).frame_id
    return frame


def message_name(frame: int) -> str:
    """The DBC name of a frame id; raises FrameError for an id the database does not know."""
    name: str = _message(frame).name
    return name


def message_names() -> dict[int, str]:
    """Every frame id in the database with its message name."""
    return {message.frame_id: message.name for message in database().messages}


def length_bytes(frame: int) -> int:
    """The data length of a message, in bytes, as the DBC gives it."""
    length: int = _message(frame).length
    return length


def period_s(frame: int) -> float:
    """The nominal period of a message, from its ``GenMsgCycleTime`` attribute."""
    cycle_time_ms = _message(frame).cycle_time
    if not cycle_time_ms:
        raise DbcError(f"message 0x{frame:03X} has no GenMsgCycleTime")
    return float(cycle_time_ms) / 1000.0


@cache
def _messages_by_id() -> dict[int, Message]:
    return {message.frame_id: message for message in database().messages}


def _message(frame: int) -> Message:
    try:
        return _messages_by_id()[frame]
    except KeyError:
        raise FrameError(f"CAN frame id 0x{frame:03X} is not in {DBC_RESOURCE}") from None


@cache
def _kind_of(frame: int) -> type[Command] | type[Report] | None:
    by_name = {kind.__name__: kind for kind in (*COMMAND_TYPES, *REPORT_TYPES)}
    message = _messages_by_id().get(frame)
    return None if message is None else by_name.get(message.name)


# --- commands ---------------------------------------------------------------------------------


@lru_cache(maxsize=CODEC_CACHE_SIZE)
def encode_command(command: Command) -> tuple[int, bytes]:
    """Frame id and payload of a command, counter and CRC included.

    Raises FrameError when a value (counter included) lies outside its DBC range: the sender is
    told at once instead of the controller rejecting the frame later.
    """
    message = database().get_message_by_name(type(command).__name__)
    raw = dbc_values.raw_values(message, command, saturate=False)
    payload = bytearray(message.encode({**raw, "crc": 0}, scaling=False, strict=True))
    payload[-1] = command_crc(message.frame_id, payload)
    return message.frame_id, bytes(payload)


def command_crc(frame: int, payload: bytes | bytearray) -> int:
    """The CRC a command frame must carry in its last byte (which is not part of the input)."""
    return crc8((frame & 0xFF, frame >> 8, *payload[:-1]))


def decode_command(frame: int, data: bytes | bytearray, previous_counter: int | None) -> Command:
    """The command in a frame, or CommandRejected; see the module docstring for the checks."""
    counter, command, out_of_range = _unpacked_command(frame, bytes(data))
    _check_counter(frame, counter, previous_counter)
    if command is None:
        raise CommandRejected(RejectReason.RANGE, frame, counter, out_of_range)
    return command


def decode_intact(frame: int, data: bytes | bytearray) -> Command:
    """The command in an intact frame (id, length, CRC and ranges good) whatever its counter, or
    CommandRejected: enough to honour a request that can only make the robot safer (a remote
    stop passes the counter and trust checks that guard against being *moved*)."""
    counter, command, out_of_range = _unpacked_command(frame, bytes(data))
    if command is None:
        raise CommandRejected(RejectReason.RANGE, frame, counter, out_of_range)
    return command


@lru_cache(maxsize=CODEC_CACHE_SIZE)
def _unpacked_command(frame: int, data: bytes) -> tuple[int, Command | None, str]:
    """Everything `decode_command` checks that depends on the frame alone: its counter and
    command, or (command None) why a value is out of range. CommandRejected for an unknown id, a
    wrong length or a bad CRC (not remembered: those frames are rare)."""
    kind = _kind_of(frame)
    if kind not in COMMAND_TYPES:
        raise CommandRejected(RejectReason.UNKNOWN_ID, frame)
    message = _message(frame)
    if len(data) != message.length:
        raise CommandRejected(RejectReason.LENGTH, frame, detail=f"{len(data)} bytes")
    if data[-1] != command_crc(frame, data):
        raise CommandRejected(RejectReason.CHECKSUM, frame)
    raw = dbc_values.raw_decode(message, data)
    try:
        command = cast(Command, dbc_values.build(kind, message, raw, check_range=True))
    except ValueError as error:
        return raw["counter"], None, str(error)
    return raw["counter"], command, ""


def _check_counter(frame: int, counter: int, previous_counter: int | None) -> None:
    if previous_counter is None or counter == (previous_counter + 1) % COUNTER_MODULUS:
        return
    detail = f"got {counter} after {previous_counter}"
    raise CommandRejected(RejectReason.COUNTER, frame, counter, detail)


# --- reports ----------------------------------------------------------------------------------


@lru_cache(maxsize=CODEC_CACHE_SIZE)
def encode_report(report: Report) -> tuple[int, bytes]:
    """Frame id and payload of a report; values outside a signal's range are saturated.

    Raises FrameError only for a value no saturation can fix (NaN).
    """
    message = database().get_message_by_name(type(report).__name__)
    raw = dbc_values.raw_values(message, report, saturate=True)
    # strict=False: raw_values has saturated every value into its range already
    return message.frame_id, bytes(message.encode(raw, scaling=False, strict=False))


def decode_report(frame: int, data: bytes | bytearray) -> Report:
    """The report in a frame; FrameError for a non-report id, a wrong length or a bad enum value."""
    return _decoded_report(frame, bytes(data))


@lru_cache(maxsize=CODEC_CACHE_SIZE)
def _decoded_report(frame: int, data: bytes) -> Report:
    kind = _kind_of(frame)
    if kind not in REPORT_TYPES:
        raise FrameError(f"CAN frame id 0x{frame:03X} is not a report")
    message = _message(frame)
    if len(data) != message.length:
        raise FrameError(f"{message.name}: {len(data)} bytes, expected {message.length}")
    raw = dbc_values.raw_decode(message, data)
    try:
        return cast(Report, dbc_values.build(kind, message, raw, False))
    except ValueError as error:
        raise FrameError(f"{message.name}: {error}") from error
