"""H5 **STOP is the whole STOP.** Whenever H1 wants the drive cut (and it is: driving on is
H1's), the hydraulic brake is at full duty and the steering pulse stays where it was when that
began (centring at speed is a swerve; with a boosted steering the pulse settles onto the held
set-point, and only the brake is judged)."""

from __future__ import annotations

from bywire.sim.verify.oracle.checks.hold import NO_HOLD, SteeringHold
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import FULL_DUTY


def check_h5(
    hold: SteeringHold, out: Outputs, cut: bool, boosted: bool, now: float
) -> tuple[SteeringHold, tuple[Violation, ...]]:
    """`cut`: H1 wants the drive cut and the e-brake is engaged."""
    if not cut:
        return NO_HOLD, ()
    found: list[Violation] = []
    duty, pulse = out.hydrobrake_duty, out.steering_pulse_s
    if duty < FULL_DUTY:
        detail = f"in STOP: hydraulic brake at {duty:.2f} duty"
        found.append(Violation.of(Invariant.H5, now, detail))
    hold, moved = hold.step(pulse, now)
    if moved and not boosted:
        held_ms = (hold.pulse_s or 0.0) * 1000
        detail = f"in STOP: steering pulse {pulse * 1000:.3f} ms, held at {held_ms:.3f} ms"
        found.append(Violation.of(Invariant.H5, now, detail, steering_held_since_s=hold.from_s))
    return hold, tuple(found)
