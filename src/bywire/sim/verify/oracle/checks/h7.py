"""H7 **a stop stops.** While the e-brake line is engaged and the robot moves, it slows by at
least `REQUIRED_DECEL_MPS2` (after `BRAKE_REACT_S` for the brakes to bite) for as long as any
brake can work: the spring brake and the hydraulic brake unless they failed, and the drive's
regenerative brake for the first `REGEN_WINDOW_S` of a stop whose cause leaves the drive healthy
(category 1). A stop that cuts the drive's power without cause throws the last brake away."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.stop import STANDSTILL_LIMIT_MPS
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import BRAKE_REACT_S, REGEN_WINDOW_S, REQUIRED_DECEL_MPS2

SPEED_SLACK_MPS = 0.05


@dataclass(frozen=True, slots=True)
class Braking:
    """H7's memory of one stop: when the e-brake engaged and at what speed, and for how long
    since then some brake could work (counted up to `seen_s`)."""

    began_s: float
    start_mps: float
    credit_s: float = 0.0
    seen_s: float = 0.0


@dataclass(frozen=True, slots=True)
class BrakeFacts:
    """What the judge knows for H7 at one instant."""

    ebrake_failed: bool
    hydrobrake_failed: bool
    drive_healthy: bool  # no cause that makes the drive suspect, and the DAC's writes work


def some_brake_works(facts: BrakeFacts, began_s: float, now: float) -> bool:
    """The spring or hydraulic brake works, or the drive can regenerate: a controlled stop's
    first `REGEN_WINDOW_S`."""
    if not (facts.ebrake_failed and facts.hydrobrake_failed):
        return True
    return facts.drive_healthy and now - began_s <= REGEN_WINDOW_S


def check_h7(
    braking: Braking | None, out: Outputs, facts: BrakeFacts, now: float
) -> tuple[Braking | None, Violation | None]:
    speed = abs(out.speed_mps)
    if out.released or speed <= STANDSTILL_LIMIT_MPS:  # a controlled stop may end there
        return None, None
    if braking is None:
        return Braking(now, speed, 0.0, now), None
    credit_s = braking.credit_s
    if some_brake_works(facts, braking.began_s, now):
        credit_s += now - braking.seen_s
    slowed_mps = REQUIRED_DECEL_MPS2 * max(credit_s - BRAKE_REACT_S, 0.0)
    allowed_mps = braking.start_mps + SPEED_SLACK_MPS - slowed_mps
    if speed <= allowed_mps:
        return Braking(braking.began_s, braking.start_mps, credit_s, now), None
    forward = out.speed_mps > 0.0
    bound = {"speed_max_mps": allowed_mps} if forward else {"speed_min_mps": -allowed_mps}
    detail = (
        f"braking since {braking.began_s:.3f} s from {braking.start_mps:.2f} m/s:"
        f" {speed:.2f} m/s, at most {allowed_mps:.2f} m/s"
    )
    # Once a stop, not at every pass after: judged afresh from here.
    return Braking(now, speed, 0.0, now), Violation.of(Invariant.H7, now, detail, **bound)
