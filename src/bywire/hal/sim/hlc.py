"""Simulated higher-level computer: sends the three commands every 20 ms, collects the reports.

Commands are built with the real codec (``dbc.encode_command``), each with its own rolling
counter, which advances only when the frame was queued (a refused frame never reached the bus,
so the next one keeps the sequence). Scenario faults: ``silence()`` (commands stop) and
``corrupt_next`` (bad CRC, wrong length, repeated counter, out-of-range value).
"""

from __future__ import annotations

import dataclasses
import enum
from collections import deque
from typing import TypeVar

from bywire.can_frame import CanFrame
from bywire.errors import FrameError
from bywire.hal.sim.can_port import SimCanPort
from bywire.hal.sim.timers import PeriodicTimer, SimClock
from bywire.model import (
    COMMAND_TYPES,
    LIGHTS_OFF,
    Command,
    ControlCommand,
    Gear,
    LightsCommand,
    MovementCommand,
    Report,
)
from bywire.protocol import dbc, dbc_values
from bywire.security.session import TRIP_IDS, SecocSigner

COMMAND_PERIOD_S = dbc.command_period_s()
ARRIVAL_HISTORY = 1000  # report arrival times kept per report type


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
        self._timer = PeriodicTimer(clock, period_s, self._send_commands)
        self.movement = MovementCommand(0.0, 0.0, 1.0, Gear.NEUTRAL, 0)
        self.lights = LIGHTS_OFF
        self.control = ControlCommand(remote_stop=False, re_enable=False, counter=0)
        self._counters: dict[type[Command], int] = dict.fromkeys(COMMAND_TYPES, 0)
        self._corruptions: dict[type[Command], deque[Corruption]] = {
            kind: deque() for kind in COMMAND_TYPES
        }
        self.frames_sent = 0
        self.send_refused = 0
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
        self._port.set_tx_mailboxes(2 * len(COMMAND_TYPES))
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
        self.movement = _checked(MovementCommand(steering_norm, throttle_norm, brake_norm, gear, 0))

    def set_lights(self, lights: LightsCommand) -> None:
        """The light requests of the next frames (their counter is this sender's own)."""
        self.lights = _checked(lights)

    def set_control(self, remote_stop: bool, re_enable: bool) -> None:
        """Remote stop and re-enable (acted on at its rising edge) of the next frames."""
        self.control = _checked(ControlCommand(remote_stop, re_enable, 0))

    def corrupt_next(
        self, count: int, kind: Corruption, message: type[Command] = MovementCommand
    ) -> None:
        """Damage the next ``count`` frames of ``message`` in the way ``kind`` says.

        ValueError for OUT_OF_RANGE on a message whose signals all fill their bits.
        """
        if kind is Corruption.OUT_OF_RANGE:
            out_of_range_payload(self._current(message))
        self._corruptions[message].extend([kind] * count)

    def _current(self, message: type[Command]) -> Command:
        current: dict[type[Command], Command] = {
            MovementCommand: self.movement,
            LightsCommand: self.lights,
            ControlCommand: self.control,
        }
        return current[message]

    def next_counter(self, message: type[Command]) -> int:
        """The counter the next frame of ``message`` will carry."""
        return self._counters[message]

    def _send_commands(self, _tick_s: float) -> None:
        if self.signer is not None and not self.signer.ready:
            self.unsigned_periods += 1  # no trip counter heard yet: nothing it could sign
            return
        for command in (self.control, self.movement, self.lights):
            self._send(command)

    def _send(self, template: Command) -> None:
        kind = type(template)
        counter = self._counters[kind]
        corruption = self._corruptions[kind].popleft() if self._corruptions[kind] else None
        if corruption is Corruption.REPEATED_COUNTER:
            counter = (counter - 1) % dbc.COUNTER_MODULUS
        command = dataclasses.replace(template, counter=counter)
        frame_id, payload = dbc.encode_command(command)
        payload = _damaged(command, payload, corruption)
        # Signs what it sends, damage included (E2E judges that), before sending: a command it
        # cannot sign is not sent at all.
        authenticator = (
            None if self.signer is None else self.signer.authenticator(frame_id, payload)
        )
        if self.signer is not None and authenticator is None:
            self.send_refused += 1
            return
        if not self._port.send(CanFrame(frame_id, payload)):
            self.send_refused += 1
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


_C = TypeVar("_C", MovementCommand, LightsCommand, ControlCommand)


def _checked(command: _C) -> _C:
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
