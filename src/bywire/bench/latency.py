"""Command → actuator latency: each command paired with the DAC write that carries its value.

A command is known by the instant it was complete on its wire (the CAN frame's last bit, the
IBUS frame's last stop bit) and by the throttle voltage it must produce. The benchmark changes the
value with every frame, so the write it caused is the first one at or after that instant that
sets exactly that voltage; the latency is the time between the two, on the simulation's clock.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from bywire.control.drive import DriveConfig, drive_outputs
from bywire.control.mux import Movement
from bywire.control.rc_mapping import RcMapping, rc_request
from bywire.model import MovementCommand
from bywire.protocol import dac6574, dbc

DEFAULT_WINDOW_S = 0.100
"""A write later than this after its command is not paired (the value has repeated by then)."""


@dataclass(frozen=True, slots=True)
class SentCommand:
    """A command as it reached the controller: when its frame was complete, what it must set."""

    completed_s: float
    throttle_volts: float


@dataclass(frozen=True, slots=True)
class DacWrite:
    """A DAC output change: when it was written and the voltage it set."""

    time_s: float
    volts: float


@dataclass(frozen=True, slots=True)
class Pairing:
    """Each command with its write (None when not found within the window)."""

    pairs: tuple[tuple[SentCommand, DacWrite | None], ...]

    @property
    def latencies_s(self) -> list[float]:
        return [write.time_s - command.completed_s for command, write in self.pairs if write]

    @property
    def unpaired(self) -> int:
        return sum(write is None for _, write in self.pairs)


def pair_writes(
    commands: Iterable[SentCommand],
    writes: Sequence[DacWrite],
    *,
    tolerance_volts: float,
    window_s: float = DEFAULT_WINDOW_S,
) -> Pairing:
    """Pair every command with the first write at or after it that sets its voltage.

    ``writes`` must be in time order (a DAC history is).
    """
    times_s = [write.time_s for write in writes]
    pairs: list[tuple[SentCommand, DacWrite | None]] = []
    for command in commands:
        index = bisect.bisect_left(times_s, command.completed_s)
        found: DacWrite | None = None
        for position in range(index, len(writes)):  # no slice: a copy per command is O(n²)
            write = writes[position]
            if write.time_s > command.completed_s + window_s:
                break
            if abs(write.volts - command.throttle_volts) <= tolerance_volts:
                found = write
                break
        pairs.append((command, found))
    return Pairing(tuple(pairs))


@dataclass(frozen=True, slots=True)
class ThrottleOutput:
    """How a throttle set-point becomes DAC volts: the drive limits and the DAC's reference."""

    drive: DriveConfig
    vref_volts: float

    @property
    def tolerance_volts(self) -> float:
        """Half a DAC code: two voltages closer than this are the same code."""
        return self.vref_volts / (2 * len(dac6574.CODES))

    def volts(self, movement: Movement) -> float:
        """The voltage the DAC outputs for this set-point while driving (quantised to a code)."""
        requested = drive_outputs(movement, enabled=True, config=self.drive).throttle_volts
        return dac6574.code_from_volts(requested, self.vref_volts).output_volts


def can_command(output: ThrottleOutput, completed_s: float, data: bytes) -> SentCommand | None:
    """A MovementCommand frame's payload as a SentCommand; None if it does not decode."""
    try:
        command = dbc.decode_command(dbc.frame_id(MovementCommand), data, None)
    except dbc.CommandRejected:
        return None
    if not isinstance(command, MovementCommand):
        return None
    movement = Movement(
        command.steering_norm, command.throttle_norm, command.brake_norm, command.gear
    )
    return SentCommand(completed_s, output.volts(movement))


def rc_command(
    output: ThrottleOutput, mapping: RcMapping, completed_s: float, channels: tuple[int, ...]
) -> SentCommand | None:
    """An IBUS frame's channels as a SentCommand; None when the frame is implausible."""
    request = rc_request(channels, mapping)
    if request is None:
        return None
    movement = Movement(
        request.steering_norm, request.throttle_norm, request.brake_norm, request.gear
    )
    return SentCommand(completed_s, output.volts(movement))
