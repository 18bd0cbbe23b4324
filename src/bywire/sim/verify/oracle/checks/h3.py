"""H3 **a watchdog trip is final.** After a trip, until the switch is put to STOP, the enable
line stays low, the e-brake engaged, the throttle at 0 V (unless the DAC's writes fail: it may
hold an old voltage) and the steering pulse where it was (not judged with a boosted steering,
whose pulse settles onto its held set-point)."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.sim.verify.oracle.checks.hold import SteeringHold
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs

TRIP_SETTLE_S = 0.010
"""The trip's own pass: the outputs are judged from this long after it."""


@dataclass(frozen=True, slots=True)
class TripFacts:
    """What the judge knows for H3 at one instant."""

    tripped_at: float | None  # the watchdog's trip not yet acknowledged at STOP
    dac_unsure: bool  # the DAC may hold an old voltage
    boosted: bool  # the steering's pulse leads its set-point


def check_h3(
    hold: SteeringHold, out: Outputs, facts: TripFacts, now: float
) -> tuple[SteeringHold, Violation | None]:
    if facts.tripped_at is None or now < facts.tripped_at + TRIP_SETTLE_S:
        return hold, None
    pulse = out.steering_pulse_s
    hold, moved = hold.step(pulse, now)
    moved = moved and not facts.boosted
    throttle = out.throttle_volts > 0.0 and not facts.dac_unsure
    if not (out.enable or out.released or throttle or moved):
        return hold, None
    detail = (
        f"after the trip: enable={out.enable} ebrake_release={out.released} "
        f"throttle={out.throttle_volts:.2f} V pulse={pulse * 1000:.3f} ms"
    )
    return hold, Violation.of(Invariant.H3, now, detail, steering_held_since_s=hold.from_s)
