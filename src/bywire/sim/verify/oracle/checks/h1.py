"""H1 **no drive without a deliberate act.** Once a stop's deadline has passed and until an
arming, the e-brake is engaged and the enable line low, or, as a controlled stop (category 1),
high with the throttle at 0 V and the regenerative brake applied: for at most
`CONTROLLED_STOP_LIMIT_S` after the stop began, never once the robot has stood still for
`STANDSTILL_GRACE_S` (with a wheel sensor that read it rolling in that stop and never died),
and never while a cause that makes the drive suspect has surely acted."""

from __future__ import annotations

from dataclasses import dataclass

from bywire.control.values import slot_init
from bywire.sim.verify.oracle.invariants import Invariant, Violation
from bywire.sim.verify.oracle.outputs import Outputs
from bywire.sim.verify.oracle.requirements import CONTROLLED_STOP_LIMIT_S, STANDSTILL_GRACE_S


@dataclass(frozen=True, slots=True)
class StopWatch:
    """H1's memory of the stop it demands: since when, and the robot's standstill in it."""

    demand_since: float | None = None
    standstill_since: float | None = None
    rolled: bool = False  # the robot clearly moved in this stop: its sensor read motion

    def __init__(
        self,
        demand_since: float | None = None,
        standstill_since: float | None = None,
        rolled: bool = False,
    ) -> None:
        object.__setattr__(self, "demand_since", demand_since)
        object.__setattr__(self, "standstill_since", standstill_since)
        object.__setattr__(self, "rolled", rolled)


slot_init(StopWatch)


NO_STOP = StopWatch()
"""No stop demanded: most passes' memory, one shared value (a frozen one is made in ~1 µs)."""


@dataclass(frozen=True, slots=True)
class StopFacts:
    """What the judge knows for H1 at one instant."""

    allowed: bool  # armed, an arming in progress, or a stop whose deadline has not passed
    power_off: bool  # a cause that makes the drive suspect has surely been acted on
    sensor_untrusted: bool  # the wheel sensor is dead or died once: its standstill is no proof
    standstill_mps: float


def check_h1(
    watch: StopWatch, out: Outputs, facts: StopFacts, now: float
) -> tuple[StopWatch, Violation | None]:
    """Driving that is not allowed at `now` (in a stop the enable line may stay high only as a
    controlled stop's)."""
    if facts.allowed:
        return NO_STOP, None
    speed = abs(out.speed_mps)
    still_since = watch.standstill_since if watch.standstill_since is not None else now
    watch = StopWatch(
        demand_since=watch.demand_since if watch.demand_since is not None else now,
        standstill_since=None if speed > 0.0 else still_since,
        rolled=watch.rolled or speed > facts.standstill_mps + 0.1,
    )
    may_last = controlled_may_last(watch, facts, now)
    controlled = out.throttle_volts <= 0.0 and out.regen_volts > 0.0 and may_last
    # A failed DAC may hold its last voltage: the enable line is what stops the motors.
    if not (out.released or (out.enable and not controlled)):
        return watch, None
    detail = (
        f"enable={out.enable} ebrake_release={out.released} throttle={out.throttle_volts:.2f} V "
        f"regen={out.regen_volts:.2f} V"
    )
    expected = {} if may_last else {"motors_enabled": False}
    return watch, Violation.of(Invariant.H1, now, detail, **expected)


def controlled_may_last(watch: StopWatch, facts: StopFacts, now: float) -> bool:
    """A controlled stop may still keep the drive powered at `now` (the time bound, the
    standstill its sensor proved: read motion in this stop, with no throttle since)."""
    if facts.power_off or watch.demand_since is None:
        return False
    if now > watch.demand_since + CONTROLLED_STOP_LIMIT_S:
        return False
    still = watch.standstill_since
    proven = watch.rolled and not facts.sensor_untrusted
    return not (proven and still is not None and now > still + STANDSTILL_GRACE_S)
