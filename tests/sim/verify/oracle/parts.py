"""The oracle's parts wired together as the judge wires them, for their tests."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.sim.verify.oracle.arming import ArmingTracker
from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from bywire.sim.verify.oracle.delays import Delays
from bywire.sim.verify.oracle.faults_in_force import FaultsInForce
from bywire.sim.verify.oracle.ledger import StopLedger

TIMING = OracleTiming()  # the defaults: frames every 7.7 ms, a debounce of 3, 100 Hz tasks


@dataclass(frozen=True, slots=True)
class Parts:
    faults: FaultsInForce
    delays: Delays
    ledger: StopLedger
    arming: ArmingTracker


def parts(timing: OracleTiming = TIMING) -> Parts:
    faults, delays = FaultsInForce(timing), Delays(timing)
    ledger = StopLedger(timing, faults, delays)
    return Parts(faults, delays, ledger, ArmingTracker(timing, ledger, faults, delays))
