"""H4 **no drive against the motion.** The motors are never driven with throttle against the
direction the robot really moves faster than the standstill threshold; judged with the wheel
sensor dead too (its standstill must not count; without it the brake held for the long dwell
proves standstill), but not once the hydraulic brake has failed as well: then nothing the
controller sees can (a double fault, `docs/SAFETY.md` row 19)."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs


@dataclass(frozen=True, slots=True)
class MotionFacts:
    """What the judge knows for H4: the wheel sensor and the hydraulic brake."""

    sensor_dead: bool
    died_at_mps: float  # the speed the sensor died at
    brake_failed: bool
    standstill_mps: float
    unnoticed_death_mps: float  # a sensor dying this slowly reads like a stop


def check_h4(out: Outputs, facts: MotionFacts, now: float) -> Violation | None:
    if not out.enable or out.throttle_volts <= 0.0 or (facts.sensor_dead and facts.brake_failed):
        return None
    speed, standstill = out.speed_mps, facts.standstill_mps
    if facts.sensor_dead and facts.died_at_mps <= facts.unnoticed_death_mps:
        # Died unnoticed while rolling this slowly: its 0 m/s reads like a stop, and the
        # robot, undriven since (driving would leave the standstill unproven), is slower.
        standstill = max(standstill, facts.died_at_mps)
    if (out.reverse and speed > standstill) or (out.forward and speed < -standstill):
        direction = "reverse" if out.reverse else "forward"
        return Violation.of(Invariant.H4, now, f"driven {direction} at {speed:.2f} m/s")
    return None
