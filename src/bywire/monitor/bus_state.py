"""What `bywire monitor` shows, as pure state: per message id, from frames and a given ``now``.

Commands are checked as the controller checks them (``dbc.decode_command`` with the previous
counter of that id, which a CRC failure forgets and a counter failure resynchronises); a rejected
frame is counted by reason and leaves the decoded values at the last good frame (no partial
update). Reports are decoded with ``dbc.decode_report``; ids not in the DBC are kept raw. The
ErrorReport's 23 one-bit flag signals are shown as one ``flags=NAME|NAME`` value.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import cantools

from bywire.error_flags import flag_names
from bywire.errors import FrameError
from bywire.model import ErrorReport
from bywire.protocol import dbc

RATE_WINDOW_S = 2.0
HIDDEN_SIGNALS = {"crc"}  # checked, not shown
BARE_UNITS = {""}  # a flag, a count, an enumeration or a normalised value: no unit (albert.dbc)


@dataclass(frozen=True, slots=True)
class SignalValue:
    """One decoded signal, formatted for display."""

    name: str
    value: str
    unit: str

    def __str__(self) -> str:
        return f"{self.name}={self.value}" + ("" if self.unit in BARE_UNITS else f" {self.unit}")


@dataclass(frozen=True, slots=True)
class MessageRow:
    """One message id as shown at ``now``."""

    arbitration_id: int
    name: str  # "" for an id the DBC does not know
    count: int
    rate_hz: float
    age_s: float
    data: bytes
    signals: tuple[SignalValue, ...]
    crc_errors: int
    counter_errors: int
    other_errors: int
    last_error: str

    @property
    def errors(self) -> int:
        """Rejected or undecodable frames of this id."""
        return self.crc_errors + self.counter_errors + self.other_errors


@dataclass(slots=True)
class _Message:
    name: str
    count: int = 0
    last_seen_s: float = 0.0
    data: bytes = b""
    signals: tuple[SignalValue, ...] = ()
    crc_errors: int = 0
    counter_errors: int = 0
    other_errors: int = 0
    last_error: str = ""
    previous_counter: int | None = None
    seen_s: deque[float] = field(default_factory=deque)


class BusModel:
    """Message table of a bus: ``add`` every frame, read ``rows(now_s)`` to show it."""

    def __init__(self, rate_window_s: float = RATE_WINDOW_S) -> None:
        self.rate_window_s = rate_window_s
        self.frames = 0
        self._messages: dict[int, _Message] = {}
        self._names = dbc.message_names()
        self._commands = frozenset(dbc.command_ids())
        self._reports = frozenset(dbc.report_ids())

    def add(self, arbitration_id: int, data: bytes, time_s: float) -> None:
        """One frame, received at ``time_s``."""
        message = self._messages.get(arbitration_id)
        if message is None:
            message = self._messages[arbitration_id] = _Message(self._names.get(arbitration_id, ""))
        self.frames += 1
        message.count += 1
        message.last_seen_s, message.data = time_s, bytes(data)
        message.seen_s.append(time_s)
        while message.seen_s[0] <= time_s - self.rate_window_s:
            message.seen_s.popleft()
        if arbitration_id in self._commands:
            self._check_command(arbitration_id, message)
        elif arbitration_id in self._reports:
            self._check_report(arbitration_id, message)

    def rows(self, now_s: float) -> list[MessageRow]:
        """Every id seen so far, lowest first, with its rate over the last window and its age."""
        messages = sorted(self._messages.items())
        return [self._row(frame, message, now_s) for frame, message in messages]

    def _row(self, arbitration_id: int, message: _Message, now_s: float) -> MessageRow:
        recent = [t for t in message.seen_s if t > now_s - self.rate_window_s]
        span_s = recent[-1] - recent[0] if len(recent) > 1 else 0.0
        return MessageRow(
            arbitration_id,
            message.name,
            message.count,
            (len(recent) - 1) / span_s if span_s > 0 else 0.0,
            max(now_s - message.last_seen_s, 0.0),
            message.data,
            message.signals,
            message.crc_errors,
            message.counter_errors,
            message.other_errors,
            message.last_error,
        )

    def _check_command(self, arbitration_id: int, message: _Message) -> None:
        try:
            command = dbc.decode_command(arbitration_id, message.data, message.previous_counter)
        except dbc.CommandRejected as rejected:
            message.previous_counter = rejected.counter
            message.last_error = str(rejected)
            if rejected.reason is dbc.RejectReason.CHECKSUM:
                message.crc_errors += 1
            elif rejected.reason is dbc.RejectReason.COUNTER:
                message.counter_errors += 1
            else:
                message.other_errors += 1
            return
        message.previous_counter = command.counter
        message.signals = _signals(arbitration_id, message.data)

    def _check_report(self, arbitration_id: int, message: _Message) -> None:
        try:
            report = dbc.decode_report(arbitration_id, message.data)
        except FrameError as error:
            message.other_errors += 1
            message.last_error = str(error)
            return
        if isinstance(report, ErrorReport):
            names = "|".join(flag_names(report.flags)) or "none"
            message.signals = (SignalValue("flags", names, ""),)
            return
        message.signals = _signals(arbitration_id, message.data)


def _signals(arbitration_id: int, data: bytes) -> tuple[SignalValue, ...]:
    """Physical values with choice names and units (the frame has passed its checks)."""
    definition = dbc.database().get_message_by_frame_id(arbitration_id)
    try:
        decoded = definition.decode_simple(data, decode_choices=True, scaling=True)
    except cantools.database.errors.DecodeError:
        return ()
    units = {signal.name: signal.unit or "" for signal in definition.signals}
    return tuple(
        SignalValue(name, _format(value), units[name])
        for name, value in decoded.items()
        if name not in HIDDEN_SIGNALS
    )


def _format(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
