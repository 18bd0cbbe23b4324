"""One receive check per CAN command message, as opendbc's `RxCheck`: what its frames must be.

A row is built from the DBC (frame id, length, counter, CRC, nominal period from its
``GenMsgCycleTime``) and the robot's timeouts (the message's own age limit,
`[timeouts.can_message_timeout_s]`, else `can_command_timeout_s`). The reader accepts only ids
that have a row; the codec checks each frame's length, CRC and counter (`bywire.protocol.dbc`);
the decision judges each message's age against its row's timeout, measured from the instant the
frame arrived (the port's timestamp), not from when the loop read it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from bywire.command_table import COMMANDS, CommandSpec
from bywire.config import TimeoutsSection
from bywire.config.consistency import CAN_TIMEOUT_PERIODS
from bywire.model import Command
from bywire.protocol import dbc

MIN_PERIODS_PER_TIMEOUT = CAN_TIMEOUT_PERIODS
"""A message's timeout spans at least two of its periods: one lost frame never stops the robot
(the loader's rule, `config.consistency`, which refuses a file that breaks it)."""


@dataclass(frozen=True, slots=True)
class RxCheck:
    """What one CAN command message's frames must be, and how old the message may get."""

    kind: type[Command]
    frame_id: int
    length_bytes: int
    counter_modulus: int  # the rolling counter in the low nibble before the CRC byte
    period_s: float  # how often the sender sends it (DBC GenMsgCycleTime)
    timeout_s: float  # older than this, the message counts as lost
    moves_the_robot: bool = True  # losing trust in it stops CAN driving (its command row's)

    @property
    def name(self) -> str:
        """The message's DBC name."""
        return self.kind.__name__

    def describe(self) -> str:
        """One line for people: id, length, checks, period and timeout."""
        return (
            f"{self.name} 0x{self.frame_id:03X}: {self.length_bytes} bytes, counter mod"
            f" {self.counter_modulus}, CRC-8 in the last byte, every"
            f" {self.period_s * 1000:g} ms, lost after {self.timeout_s * 1000:g} ms"
        )


def rx_checks(timeouts: TimeoutsSection) -> tuple[RxCheck, ...]:
    """The receive check of every CAN command message, in the command table's order."""
    return tuple(_row(spec, timeouts.can_timeout_s(spec.name)) for spec in COMMANDS)


def rx_check(checks: Sequence[RxCheck], kind: type[Command]) -> RxCheck:
    """The row of the message `kind` (LookupError if `checks` has none)."""
    for check in checks:
        if check.kind is kind:
            return check
    raise LookupError(f"no receive check for {kind.__name__}")


def _row(spec: CommandSpec, timeout_s: float) -> RxCheck:
    frame_id = dbc.frame_id(spec.kind)
    return RxCheck(
        kind=spec.kind,
        frame_id=frame_id,
        length_bytes=dbc.length_bytes(frame_id),
        counter_modulus=dbc.COUNTER_MODULUS,
        period_s=dbc.period_s(frame_id),
        timeout_s=timeout_s,
        moves_the_robot=spec.moves_the_robot,
    )
