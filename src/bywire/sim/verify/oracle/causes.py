"""What demands STOP, as the oracle is told it: one enum, and the groups the rules need.

`OracleCause` is the oracle's own model, kept independent of the controller's latched causes
(`bywire.control.supervisor.Cause`): it names what was done to the robot, not what the
controller concluded. `tests/sim/verify/oracle/test_causes.py` names every controller cause
it does not model."""

from __future__ import annotations

from enum import Enum


class OracleCause(Enum):
    """Something done to the robot that demands STOP (an act, or a fault while in force)."""

    SWITCH_STOP = "switch_stop"  # the mode switch moved to STOP (or bounced through it)
    RC_FAILSAFE = "rc_failsafe"  # the receiver sends its failsafe values
    RC_IMPLAUSIBLE = "rc_implausible"  # intact frames carry a pulse no stick gives
    RC_LINK_LOST = "rc_link_lost"  # no frame arrives
    REMOTE_STOP = "remote_stop"  # the computer asks for a stop
    CAN_LOST = "can_lost"  # the computer is silent
    CAN_UNPLUGGED = "can_unplugged"  # the CAN cable is pulled
    CAN_IMPOSTOR = "can_impostor"  # a second sender on the computer's id
    DAC_FAIL = "dac_fail"  # DAC writes are NAKed
    DAC_SLOW = "dac_slow"  # every DAC transfer crawls, slower than any budget
    WATCHDOG = "watchdog"  # the loop stalled past the watchdog's limit
    ESTOP_PRESSED = "estop_pressed"  # the E-stop is pressed (or bounces while pressed)
    ESTOP_WIRE = "estop_wire"  # the E-stop's wire is broken


RC_BORNE = frozenset({OracleCause.SWITCH_STOP, OracleCause.RC_IMPLAUSIBLE, OracleCause.RC_FAILSAFE})
"""Causes the IBUS frames carry: corrupted frames may delay them."""
CAN_SILENT = frozenset({OracleCause.CAN_LOST, OracleCause.CAN_UNPLUGGED})
"""Faults in which nothing the computer sends arrives."""
CAN_ONLY = frozenset({*CAN_SILENT, OracleCause.CAN_IMPOSTOR, OracleCause.REMOTE_STOP})
"""Causes that stop CAN mode and refuse arming into CAN, never RC."""
CAN_MODE_ONLY = frozenset({*CAN_SILENT, OracleCause.CAN_IMPOSTOR})
"""Causes that stop the robot only once it is in CAN mode: a move to CAN stops it once the move
counts (a remote stop is honoured in every mode)."""
ESTOP = frozenset({OracleCause.ESTOP_PRESSED, OracleCause.ESTOP_WIRE})
"""The E-stop's circuit open: a press, a broken wire (issue 44)."""
SWITCH_ONLY = frozenset(
    {
        OracleCause.RC_LINK_LOST,
        OracleCause.RC_FAILSAFE,
        OracleCause.DAC_FAIL,
        OracleCause.DAC_SLOW,
        *ESTOP,
    }
)
"""Faults whose latched cause only the operator's switch clears, never a CAN re-enable (S8);
implausible frames and the watchdog's trip are such too, and so is a second sender once it has
surely latched (`StopLedger.latched_from`)."""
POWER_OFF = frozenset({OracleCause.DAC_FAIL, OracleCause.DAC_SLOW, OracleCause.WATCHDOG, *ESTOP})
"""Causes that make the drive suspect, and the E-stop (ISO 13850): category 0, enable low."""
