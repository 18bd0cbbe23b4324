"""The faults in force, as the oracle was told them: when each began and whether the robot was
armed then, and what the DAC's writes have been doing."""

from __future__ import annotations

from collections.abc import Set
from dataclasses import dataclass, field

from bywire.sim.verify.oracle.cause_deadlines import OracleTiming
from bywire.sim.verify.oracle.causes import CAN_ONLY, OracleCause


@dataclass(slots=True)
class FaultsInForce:
    """Every fault in force, and what its beginning found."""

    timing: OracleTiming
    causes: set[OracleCause] = field(default_factory=set)
    changed_at: float = -1.0  # when a fault last began or ended
    began: dict[OracleCause, tuple[float, bool]] = field(default_factory=dict)  # (at, armed then)
    impostor_met_drive: bool = False  # the motors were enabled when a second sender began
    impostor_counts_s: float = 0.0  # and the switch's move to CAN counts then (past: counted)
    dac_every_other: bool = False  # the failing DAC NAKs every other write: slower to latch
    dac_back_at: float = -1.0  # when DAC writes last began to succeed again
    dac_writes_from: float = -1.0  # the loop writes the DAC (no watchdog trip holds the gate)

    def __contains__(self, cause: OracleCause) -> bool:
        return cause in self.causes

    def any_of(self, group: Set[OracleCause]) -> bool:
        return bool(self.causes & group)

    def note(self, cause: OracleCause, now: float) -> None:
        """`cause` is in force without stopping the robot (a CAN-bound fault while RC drives:
        it refuses an arming into CAN)."""
        self.causes.add(cause)
        self.changed_at = now

    def blocking(self, target_rc: bool, now: float) -> bool:
        """A fault that must refuse an arming (into RC: not a CAN-bound one) has been in force
        a while."""
        blocking = self.causes - CAN_ONLY if target_rc else self.causes
        return bool(blocking) and now - self.changed_at > 0.3

    def unnoticed_s(self, cause: OracleCause) -> float:
        """How long `cause` must last before the controller can have noticed it."""
        if cause is OracleCause.DAC_FAIL and self.dac_every_other:
            # four failing writes, each a driving period apart, and a period for the first
            return 5 * self.timing.driving_period_s
        return self.timing.unnoticed_s(cause)

    def dac_unsure(self, now: float) -> bool:
        """A DAC whose writes fail may hold an old voltage until a period after they work."""
        rewrite_s = self.dac_back_at + 2 * self.timing.control_period_s
        return OracleCause.DAC_FAIL in self.causes or now <= rewrite_s
