"""H2 **bumpless handover.** Once the switch has settled on a source (its debounce's frames
arrived), throttle volts above zero with the motors enabled mean that source has been seen at
zero throttle since the switch moved to it."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.model import ControlMode
from bywire.sim.verify.oracle.invariants import Invariant, Violation


@dataclass(frozen=True, slots=True)
class HandoverFacts:
    """What the judge knows for H2 at one instant."""

    switch: ControlMode
    settled_s: float  # from when the controller surely acts on the switch's position
    seen_zero: bool  # the source at the switch was seen at zero throttle since it moved there


def check_h2(facts: HandoverFacts, drive_volts: float, now: float) -> Violation | None:
    """`drive_volts`: the throttle volts while the motors are enabled (else 0)."""
    if drive_volts <= 0.0 or facts.switch is ControlMode.STOP or now < facts.settled_s:
        return None
    if facts.seen_zero:
        return None
    detail = f"{facts.switch.name} never at zero throttle; throttle={drive_volts:.2f} V"
    return Violation.of(Invariant.H2, now, detail)
