"""`bywire verify`'s judge: the hazard oracle (`judge.HazardOracle`), built of small typed parts
(see `judge.py`), and the invariants it checks."""

from bywire.sim.verify.oracle.cause_deadlines import OracleTiming, ServoPulses
from bywire.sim.verify.oracle.causes import OracleCause
from bywire.sim.verify.oracle.invariants import INVARIANTS, SAFE_LEVELS, Invariant, Violation
from bywire.sim.verify.oracle.judge import HazardOracle

__all__ = [
    "INVARIANTS",
    "SAFE_LEVELS",
    "HazardOracle",
    "Invariant",
    "OracleCause",
    "OracleTiming",
    "ServoPulses",
    "Violation",
]
