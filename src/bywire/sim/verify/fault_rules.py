"""What the oracle must expect when a fault is injected: the rule each row of `faults.FAULTS`
carries (`Fault.expect`), told to the oracle by the campaign's witness (`witness.py`).

A rule gets the witness (the oracle, and what the campaign has done so far: the remote stop
asked for, commands authenticated or not), the fault's values and the time it was injected.
A fault the oracle never needs to know of (a flood, the steering failing, a second sender on
the lights' id, frames sent twice) has `nothing`: it may stop the robot or not.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

from bywire.model import ControlMode
from bywire.protocol import dbc
from bywire.sim.verify.oracle.causes import Cause

if TYPE_CHECKING:
    from bywire.sim.verify.witness import OracleWitness

FaultValues = Mapping[str, Any]
Expect = Callable[["OracleWitness", FaultValues, float], None]

IMPOSTOR_PERIOD_S = dbc.command_period_s()  # a second sender keeps the commands' period
"""A second sender, like the computer, sends one frame per command period."""


def _count(values: FaultValues) -> int:
    return int(values.get("count", 1))


def nothing(_witness: OracleWitness, _values: FaultValues, _now: float) -> None:
    """The oracle never needs to know whether this stopped the robot."""


def begins(cause: Cause) -> Expect:
    """`cause` is in force from now: it demands STOP."""

    def expect(witness: OracleWitness, _values: FaultValues, now: float) -> None:
        witness.oracle.fault(cause, True, now)

    return expect


def ends(cause: Cause) -> Expect:
    """`cause` is over (what it latched stays latched)."""

    def expect(witness: OracleWitness, _values: FaultValues, now: float) -> None:
        witness.oracle.fault(cause, False, now)

    return expect


def can_fault(cause: Cause) -> Expect:
    """A CAN-bound fault begins: it stops CAN mode, and refuses an arming into CAN."""

    def expect(witness: OracleWitness, _values: FaultValues, now: float) -> None:
        witness.can_fault(cause, True, now)

    return expect


def can_back(cause: Cause) -> Expect:
    """A CAN-bound fault ends: a remote stop asked for meanwhile arrives now."""

    def expect(witness: OracleWitness, _values: FaultValues, now: float) -> None:
        witness.can_back(cause, now)

    return expect


def rc_frames_lost(frames: Callable[[int], int]) -> Expect:
    """`frames(count)` IBUS frames may be lost: what they carry arrives late, or never."""

    def expect(witness: OracleWitness, values: FaultValues, now: float) -> None:
        oracle = witness.oracle
        until_s = now + frames(_count(values)) * oracle.timing.frame_s
        oracle.blind(ControlMode.RC, now, until_s)

    return expect


def can_frames_lost(witness: OracleWitness, values: FaultValues, now: float) -> None:
    """The next `count` command frames are dropped (and the one in flight)."""
    until_s = now + (_count(values) + 1) * IMPOSTOR_PERIOD_S
    witness.oracle.blind(ControlMode.CAN, now, until_s)


def switch_chatter(witness: OracleWitness, values: FaultValues, now: float) -> None:
    witness.oracle.chatter(_count(values), now)


def rc_implausible(witness: OracleWitness, values: FaultValues, now: float) -> None:
    witness.oracle.implausible(_count(values), now)


def second_sender(witness: OracleWitness, values: FaultValues, now: float) -> None:
    """A second node on the computer's movement id, with the key or without."""
    witness.second_sender(_count(values), bool(values.get("keyed")), now)


def dac_fails(*, every_other: bool) -> Expect:
    def expect(witness: OracleWitness, _values: FaultValues, now: float) -> None:
        witness.oracle.dac_failing(now, every_other=every_other)

    return expect


def dac_restored(witness: OracleWitness, _values: FaultValues, now: float) -> None:
    witness.dac_restored(now)


def dac_slow(witness: OracleWitness, values: FaultValues, now: float) -> None:
    witness.slow_dac(float(values["stall_s"]), now)


def dac_stall(witness: OracleWitness, values: FaultValues, now: float) -> None:
    witness.stall(float(values["stall_s"]), now)


def line_dead(witness: OracleWitness, values: FaultValues, _now: float) -> None:
    witness.oracle.line_died(str(values["line"]))


def ebrake_fails(witness: OracleWitness, _values: FaultValues, _now: float) -> None:
    witness.oracle.ebrake_fails()


def hydrobrake(*, failed: bool) -> Expect:
    def expect(witness: OracleWitness, _values: FaultValues, _now: float) -> None:
        witness.oracle.hydrobrake_fails(failed)

    return expect


def servo(*, stuck: bool) -> Expect:
    def expect(witness: OracleWitness, _values: FaultValues, _now: float) -> None:
        witness.oracle.servo_stuck(stuck)

    return expect


def wheel_sensor(*, dead: bool) -> Expect:
    def expect(witness: OracleWitness, _values: FaultValues, _now: float) -> None:
        if dead:
            witness.oracle.sensor_dies()
        else:
            witness.oracle.sensor_restored()

    return expect
