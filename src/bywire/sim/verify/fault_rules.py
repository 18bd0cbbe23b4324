"""What the oracle must expect when a fault is injected: one rule per row of the scenario
language's fault table (`sim/faults.py`, by name: `RULES`), told to the oracle by the campaign's
witness (`witness.py`).

A rule gets the witness (the oracle, and what the campaign has done so far: the remote stop
asked for, commands authenticated or not), the fault's values and the time it was injected.
A fault the oracle never needs to know of (a flood, the steering failing, a second sender on
the lights' id, frames sent twice) has `nothing`: it may stop the robot or not.
`tests/sim/verify/test_fault_rules.py` fails when a fault of the table has no rule here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from bywire.model import ControlMode
from bywire.protocol import dbc
from bywire.sim.faults import FaultValues
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.judge import HazardOracle


class Witness(Protocol):
    """What a rule may tell (`witness.OracleWitness` is the one): the oracle, and the events
    whose meaning depends on what the campaign has done so far."""

    @property
    def oracle(self) -> HazardOracle: ...
    def can_fault(self, cause: OracleCause, active: bool, now: float) -> None: ...
    def can_back(self, cause: OracleCause, now: float) -> None: ...
    def second_sender(self, frames: int, keyed: bool, now: float) -> None: ...
    def dac_restored(self, now: float) -> None: ...
    def slow_dac(self, transfer_s: float, now: float) -> None: ...
    def stall(self, stall_s: float, now: float) -> None: ...


Expect = Callable[[Witness, FaultValues, float], None]

IMPOSTOR_PERIOD_S = dbc.command_period_s()  # a second sender keeps the commands' period
"""A second sender, like the computer, sends one frame per command period."""


def _count(values: FaultValues) -> int:
    return int(values.get("count", 1))


def nothing(_witness: Witness, _values: FaultValues, _now: float) -> None:
    """The oracle never needs to know whether this stopped the robot."""


def begins(cause: OracleCause) -> Expect:
    """`cause` is in force from now: it demands STOP."""

    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        witness.oracle.fault(cause, True, now)

    return expect


def ends(cause: OracleCause) -> Expect:
    """`cause` is over (what it latched stays latched)."""

    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        witness.oracle.fault(cause, False, now)

    return expect


def can_fault(cause: OracleCause) -> Expect:
    """A CAN-bound fault begins: it stops CAN mode, and refuses an arming into CAN."""

    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        witness.can_fault(cause, True, now)

    return expect


def can_back(cause: OracleCause) -> Expect:
    """A CAN-bound fault ends: a remote stop asked for meanwhile arrives now."""

    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        witness.can_back(cause, now)

    return expect


def rc_frames_lost(frames: Callable[[int], int]) -> Expect:
    """`frames(count)` IBUS frames may be lost: what they carry arrives late, or never (noise
    garbles the frames it covers: `SimRcTransmitter.inject_bytes`)."""

    def expect(witness: Witness, values: FaultValues, now: float) -> None:
        oracle = witness.oracle
        until_s = now + frames(_count(values)) * oracle.timing.frame_s
        oracle.blind(ControlMode.RC, now, until_s)

    return expect


def can_frames_lost(witness: Witness, values: FaultValues, now: float) -> None:
    """The next `count` command frames are dropped (and the one in flight)."""
    until_s = now + (_count(values) + 1) * IMPOSTOR_PERIOD_S
    witness.oracle.blind(ControlMode.CAN, now, until_s)


def switch_chatter(witness: Witness, values: FaultValues, now: float) -> None:
    witness.oracle.chatter(_count(values), now)


def rc_implausible(witness: Witness, values: FaultValues, now: float) -> None:
    witness.oracle.implausible(_count(values), now)


def second_sender(witness: Witness, values: FaultValues, now: float) -> None:
    """A second node on the computer's movement id, with the key or without."""
    witness.second_sender(_count(values), bool(values.get("keyed")), now)


def dac_fails(*, every_other: bool) -> Expect:
    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        witness.oracle.dac_failing(now, every_other=every_other)

    return expect


def dac_restored(witness: Witness, _values: FaultValues, now: float) -> None:
    witness.dac_restored(now)


def dac_slow(witness: Witness, values: FaultValues, now: float) -> None:
    witness.slow_dac(float(values["stall_s"]), now)


def dac_stall(witness: Witness, values: FaultValues, now: float) -> None:
    witness.stall(float(values["stall_s"]), now)


def line_dead(witness: Witness, values: FaultValues, _now: float) -> None:
    witness.oracle.line_died(str(values["line"]))


def ebrake_fails(witness: Witness, _values: FaultValues, _now: float) -> None:
    witness.oracle.ebrake_fails()


def hydrobrake(*, failed: bool) -> Expect:
    def expect(witness: Witness, _values: FaultValues, _now: float) -> None:
        witness.oracle.hydrobrake_fails(failed)

    return expect


def servo(*, stuck: bool) -> Expect:
    def expect(witness: Witness, _values: FaultValues, _now: float) -> None:
        witness.oracle.servo_stuck(stuck)

    return expect


def wheel_sensor(*, dead: bool) -> Expect:
    def expect(witness: Witness, _values: FaultValues, _now: float) -> None:
        if dead:
            witness.oracle.sensor_dies()
        else:
            witness.oracle.sensor_restored()

    return expect


def estop(cause: OracleCause, *, opens: bool) -> Expect:
    """The E-stop's circuit opens (`cause` begins: STOP, category 0) or closes (it ends), on a
    robot whose controller has the button wired (`[estop] line`); on one without, the button is
    no input at all and the oracle expects nothing of it."""

    def expect(witness: Witness, _values: FaultValues, now: float) -> None:
        if witness.oracle.world.hardware.estop_line is not None:
            witness.oracle.fault(cause, opens, now)

    return expect


# fmt: off
RULES: dict[str, Expect] = {
    "rc_link_lost": begins(OracleCause.RC_LINK_LOST),
    "rc_link_restored": ends(OracleCause.RC_LINK_LOST),
    "rc_failsafe": begins(OracleCause.RC_FAILSAFE),
    "rc_failsafe_off": ends(OracleCause.RC_FAILSAFE),
    "ibus_garbage": rc_frames_lost(lambda n: n // 32 + 2),
    "ibus_corrupt": rc_frames_lost(lambda n: n + 1),
    "can_silence": can_fault(OracleCause.CAN_LOST),
    "can_resume": can_back(OracleCause.CAN_LOST),
    "can_corrupt_crc": can_frames_lost,
    "can_corrupt_length": can_frames_lost,
    "can_corrupt_counter": can_frames_lost,
    "can_corrupt_range": can_frames_lost,
    "dac_fail": dac_fails(every_other=False),
    "dac_restore": dac_restored,
    "can_unplug": can_fault(OracleCause.CAN_UNPLUGGED),
    "can_plug": can_back(OracleCause.CAN_UNPLUGGED),
    "can_flood": nothing,
    "can_flood_off": nothing,
    "hydrobrake_fail": hydrobrake(failed=True),
    "hydrobrake_restore": hydrobrake(failed=False),
    "ebrake_fail": ebrake_fails,
    "servo_stuck": servo(stuck=True),
    "servo_free": servo(stuck=False),
    "encoder_fail": nothing,
    "loop_stall": nothing,
    "dac_stall": dac_stall,
    "dac_nak_alternate": dac_fails(every_other=True),
    "switch_chatter": switch_chatter,
    "switch_dither": nothing,
    "rc_implausible": rc_implausible,
    "can_impostor": second_sender,
    "can_impostor_control": nothing,
    "can_forgery": second_sender,
    "can_skip_forgery": second_sender,
    "can_doubles": nothing,
    "can_impostor_lights": nothing,
    "dac_slow": dac_slow,
    "line_dead": line_dead,
    "wheel_sensor_dead": wheel_sensor(dead=True),
    "wheel_sensor_restore": wheel_sensor(dead=False),
    "estop_press": estop(OracleCause.ESTOP_PRESSED, opens=True),
    "estop_release": estop(OracleCause.ESTOP_PRESSED, opens=False),
    "estop_wire_break": estop(OracleCause.ESTOP_WIRE, opens=True),
    "estop_wire_mend": estop(OracleCause.ESTOP_WIRE, opens=False),
    # a press that bounces: its first read is open, so it acts at once, as a press does
    "estop_chatter": estop(OracleCause.ESTOP_PRESSED, opens=True),
}
# fmt: on
"""Each fault's rule, by its name in `faults.FAULTS`."""
