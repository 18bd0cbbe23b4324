"""Simulated higher-level computer: sends every command row each period, collects the reports.

It sends each row of the command table (`bywire.command_table.COMMANDS`) every period, in the
table's order: the row's `neutral` frame until told otherwise (`set_command`). Its transmit
mailboxes are sized from the table (`mailboxes_needed`), so a new row goes out like the others;
a frame the port still refuses is counted by message (`refused`), never dropped unseen.

Commands are built with the real codec (``dbc.encode_command``), each with its own rolling
counter, which advances only when the frame was queued (a refused frame never reached the bus,
so the next one keeps the sequence). Scenario faults: ``silence()`` (commands stop) and
``corrupt_next`` (bad CRC, wrong length, repeated counter, out-of-range value).
"""

from __future__ import annotations

import enum
from collections import Counter, deque
from typing import TypeVar, cast

from bywire.can_frame import CanFrame
from bywire.command_table import COMMANDS, command_row
from bywire.errors import FrameError
from bywire.hal.simulated.can_port import SimCanPort
from bywire.hal.simulated.timers import PeriodicTimer, SimClock
from bywire.model import (
    Command,
    ControlCommand,
    Gear,
    LightsCommand,
    MovementCommand,
    Report,
    with_counter,
)
from bywire.protocol import dbc, dbc_values
from bywire.security.session import TRIP_IDS, SecocSigner

COMMAND_PERIOD_S = dbc.command_period_s()
ARRIVAL_HISTORY = 1000  # report arrival times kept per report type
C = TypeVar("C", bound=Command)


def mailboxes_needed(signing: bool = False) -> int:
    """Transmit mailboxes for one period's commands queued at once: one per command row, two
    when each frame is followed by its SecOC authenticator."""
    return (2 if signing else 1) * len(COMMANDS)


class Corruption(enum.Enum):
    """How ``corrupt_next`` damages a frame; each matches one ``dbc.RejectReason``."""

    BAD_CRC = dbc.RejectReason.CHECKSUM
    WRONG_LENGTH = dbc.RejectReason.LENGTH
    REPEATED_COUNTER = dbc.RejectReason.COUNTER
    OUT_OF_RANGE = dbc.RejectReason.RANGE


def out_of_range_payload(command: Command) -> bytes:
    """The command's frame with its first range-limited signal one step above its maximum.

    The CRC is recomputed, so only the range check can catch it. ValueError if every signal of
    this command fills its bits (nothing can be out of range).
    """
    message = dbc.database().get_message_by_name(type(command).__name__)
    raw = dbc_values.raw_values(message, command, saturate=False)
    for signal in message.signals:
        _, high = dbc_values.raw_bounds(signal)
        if signal.name in raw and high < (1 << (signal.length - int(signal.is_signed))) - 1:
            raw[signal.name] = high + 1
            payload = bytearray(message.encode({**raw, "crc": 0}, scaling=False, strict=False))
            payload[-1] = dbc.command_crc(message.frame_id, payload)
            return bytes(payload)
    raise ValueError(f"no signal of {type(command).__name__} can hold an out-of-range value")


class SimHigherLevelComputer:
    """The autonomy computer's side of the CAN protocol, on one port of the simulated bus."""

    def __init__(
        self, clock: SimClock, port: SimCanPort, period_s: float = COMMAND_PERIOD_S
    ) -> None:
        self._port = port
        port.set_tx_mailboxes(mailboxes_needed())
        self._timer = PeriodicTimer(clock, period_s, self._send_commands)
        self._commands: dict[type[Command], Command] = {
            spec.kind: spec.neutral for spec in COMMANDS
        }
        self._counters: dict[type[Command], int] = {spec.kind: 0 for spec in COMMANDS}
        self._corruptions: dict[type[Command], deque[Corruption]] = {
            spec.kind: deque() for spec in COMMANDS
        }
        self.frames_sent = 0
        self.send_refused = 0
        self.refused: Counter[str] = Counter()
        """Frames refused (not signed, or the port full or bus-off), by DBC message name."""
        self.report_errors = 0
        self._latest: dict[type[Report], tuple[float, Report]] = {}
        self._arrivals: dict[type[Report], deque[float]] = {}
        self._report_ids = frozenset(dbc.report_ids())
        self.signer: SecocSigner | None = None
        self.doubles_pending = 0  # frames to send twice, same counter and payload
        self.unsigned_periods = 0  # periods skipped while signing, before a trip counter came
        port.set_listener(self._on_frame)

    def sign_with(self, signer: SecocSigner) -> None:
        """Authenticated commands: each frame is followed by its SecOC cryptographic PDU, signed
        in the trip the controller announces (no command goes out before it is heard)."""
        self.signer = signer
        self._port.set_tx_mailboxes(mailboxes_needed(signing=True))
        if self._port.accept_ids is not None:  # its filter lets the trip counter through too
            self._port.set_filter(self._port.accept_ids | TRIP_IDS)

    # --- commands --------------------------------------------------------------------------------

    def start(self, first_s: float | None = None) -> None:
        """Send every command each period from ``first_s`` (default now)."""
        self._timer.start(first_s)

    def silence(self) -> None:
        """Stop sending (the "CAN commands stop" fault); ``start()`` resumes."""
        self._timer.stop()

    @property
    def sending(self) -> bool:
        """True while commands go out every period."""
        return self._timer.running

    def set_movement(
        self, steering_norm: float, throttle_norm: float, brake_norm: float, gear: Gear
    ) -> None:
        """The movement set-points of the next frames (default: full brake, neutral).

        FrameError at once for a value outside its DBC range (``corrupt_next`` sends those).
        """
        self.set_command(MovementCommand(steering_norm, throttle_norm, brake_norm, gear, 0))

    def set_lights(self, lights: LightsCommand) -> None:
        """The light requests of the next frames (their counter is this sender's own)."""
        self.set_command(lights)

    def set_control(self, remote_stop: bool, re_enable: bool) -> None:
        """Remote stop and re-enable (acted on at its rising edge) of the next frames."""
        self.set_command(ControlCommand(remote_stop, re_enable, 0))

    def set_command(self, command: Command) -> None:
        """What the next frames of this command's row carry (their counter is this sender's own).

        FrameError at once for a value outside its DBC range (``corrupt_next`` sends those);
        LookupError for a command without a row.
        """
        command_row(type(command))
        self._commands[type(command)] = _checked(command)

    def current(self, kind: type[C]) -> C:
        """What the next frame of `kind` carries (its row's `neutral` until set)."""
        return cast(C, self._commands[kind])  # keyed by its own type (`set_command`)

    def corrupt_next(
        self, count: int, kind: Corruption, message: type[Command] = MovementCommand
    ) -> None:
        """Damage the next ``count`` frames of ``message`` in the way ``kind`` says.

        ValueError for OUT_OF_RANGE on a message whose signals all fill their bits.
        """
        if kind is Corruption.OUT_OF_RANGE:
            out_of_range_payload(self._commands[message])
        self._corruptions[message].extend([kind] * count)

    def next_counter(self, message: type[Command]) -> int:
        """The counter the next frame of ``message`` will carry."""
        return self._counters[message]

    def _send_commands(self, _tick_s: float) -> None:
        if self.signer is not None and not self.signer.ready:
            self.unsigned_periods += 1  # no trip counter heard yet: nothing it could sign
            return
        for command in self._commands.values():  # the table's order
            self._send(command)

    def _send(self, template: Command) -> None:
        kind = type(template)
        counter = self._counters[kind]
        corruption = self._corruptions[kind].popleft() if self._corruptions[kind] else None
        if corruption is Corruption.REPEATED_COUNTER:
            counter = (counter - 1) % dbc.COUNTER_MODULUS
        command = with_counter(template, counter)
        frame_id, payload = dbc.encode_command(command)
        payload = _damaged(command, payload, corruption)
        # Signs what it sends, damage included (E2E judges that), before sending: a command it
        # cannot sign is not sent at all.
        authenticator = (
            None if self.signer is None else self.signer.authenticator(frame_id, payload)
        )
        if (self.signer is not None and authenticator is None) or not self._port.send(
            CanFrame(frame_id, payload)
        ):
            self.send_refused += 1
            self.refused[kind.__name__] += 1
            return
        self.frames_sent += 1
        if authenticator is not None:
            self._port.send(authenticator)
        if self.doubles_pending > 0 and kind is MovementCommand:  # the driver's bug, or redundancy
            self.doubles_pending -= 1
            self._send_again(frame_id, payload)
        if corruption is not Corruption.REPEATED_COUNTER:
            self._counters[kind] = (counter + 1) % dbc.COUNTER_MODULUS

    def _send_again(self, frame_id: int, payload: bytes) -> None:
        """The same frame once more, same counter and payload (signed afresh when signing: a
        sender's freshness value is never used twice)."""
        authenticator = (
            None if self.signer is None else self.signer.authenticator(frame_id, payload)
        )
        if self.signer is not None and authenticator is None:
            return
        if self._port.send(CanFrame(frame_id, payload)):
            self.frames_sent += 1
            if authenticator is not None:
                self._port.send(authenticator)

    # --- reports ---------------------------------------------------------------------------------

    def latest(self, kind: type[Report]) -> Report | None:
        """The newest report of this type, None before the first."""
        entry = self._latest.get(kind)
        return None if entry is None else entry[1]

    def latest_at(self, kind: type[Report]) -> float | None:
        """When the newest report of this type arrived."""
        entry = self._latest.get(kind)
        return None if entry is None else entry[0]

    def arrivals(self, kind: type[Report]) -> list[float]:
        """Arrival times of the latest reports of this type (up to ARRIVAL_HISTORY)."""
        return list(self._arrivals.get(kind, ()))

    def _on_frame(self, frame: CanFrame) -> None:
        if self.signer is not None and frame.arbitration_id in TRIP_IDS:
            self.signer.hear(frame.arbitration_id, frame.data)
            return
        if frame.arbitration_id not in self._report_ids:
            return
        try:
            report = dbc.decode_report(frame.arbitration_id, frame.data)
        except FrameError:
            self.report_errors += 1
            return
        kind = type(report)
        self._latest[kind] = (frame.timestamp_s, report)
        self._arrivals.setdefault(kind, deque(maxlen=ARRIVAL_HISTORY)).append(frame.timestamp_s)


def _checked(command: C) -> C:
    """The command, once the codec has accepted its values (raises FrameError otherwise)."""
    dbc.encode_command(command)
    return command


def _damaged(command: Command, payload: bytes, corruption: Corruption | None) -> bytes:
    if corruption is Corruption.BAD_CRC:
        return payload[:-1] + bytes((payload[-1] ^ 0x5A,))
    if corruption is Corruption.WRONG_LENGTH:
        return payload[:-1]
    if corruption is Corruption.OUT_OF_RANGE:
        return out_of_range_payload(command)
    return payload
